#include "io/output_folder.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>

#include "sim/error.h"

namespace dg::io {
namespace {

namespace fs = std::filesystem;

// The pid the holder wrote, or empty when the file holds none yet.
std::string HolderPid(int fd) {
  char text[32] = {};
  const ssize_t n = pread(fd, text, sizeof text - 1, 0);
  std::string pid = n > 0 ? std::string(text, static_cast<size_t>(n)) : std::string();
  while (!pid.empty() && (pid.back() == '\n' || pid.back() == ' ')) pid.pop_back();
  return pid;
}

}  // namespace

bool MatchesOutputName(const std::string& name, const std::string& pattern) {
  const size_t star = pattern.find('*');
  if (star == std::string::npos) return name == pattern;
  const std::string head = pattern.substr(0, star), tail = pattern.substr(star + 1);
  return name.size() >= head.size() + tail.size() && name.compare(0, head.size(), head) == 0 &&
         name.compare(name.size() - tail.size(), tail.size(), tail) == 0;
}

namespace {

// Takes the lock on the open lock file and writes this process's pid into it.
void LockAndSign(int fd, const std::string& lock_path, const std::string& folder, const std::string& command) {
  if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int cause = errno;
    if (cause == EWOULDBLOCK) {
      const std::string pid = HolderPid(fd);
      throw Error("the output folder is in use by another dynaguide process" + (pid.empty() ? "" : " (pid " + pid + ")"),
                  folder, "wait for it to finish, or give " + command + " another --out");
    }
    throw Error(std::string("cannot lock the output folder: ") + std::strerror(cause), lock_path,
                "use a local file system that supports flock for --out");
  }
  const std::string pid = std::to_string(getpid()) + "\n";
  if (ftruncate(fd, 0) != 0 || pwrite(fd, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size())) {
    throw Error(std::string("cannot write the lock file: ") + std::strerror(errno), lock_path,
                "free space on the output's file system or choose another --out");
  }
}

// Removes the folder's files named like `outputs` that are not among `inputs`; returns their names.
std::vector<std::string> RemoveStale(const std::string& folder, const std::vector<std::string>& outputs,
                                     const std::vector<std::string>& inputs) {
  std::error_code error;
  std::vector<fs::path> stale;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    const auto is_input = [&](const std::string& input) { return fs::equivalent(entry.path(), input, error); };
    if (std::any_of(outputs.begin(), outputs.end(), [&](const std::string& p) { return MatchesOutputName(name, p); }) &&
        std::none_of(inputs.begin(), inputs.end(), is_input)) {
      stale.push_back(entry.path());
    }
  }
  std::vector<std::string> removed;
  for (const fs::path& path : stale) {
    if (!fs::remove(path, error) && error) {
      throw Error("cannot remove an earlier run's output: " + error.message(), path.string(),
                  "remove it by hand or choose another --out");
    }
    removed.push_back(path.filename().string());
  }
  return removed;
}

}  // namespace

OutputFolderClaim::OutputFolderClaim(const std::string& folder, const std::string& command,
                                     const std::vector<std::string>& outputs,
                                     const std::vector<std::string>& inputs) {
  std::error_code error;
  if (fs::exists(folder, error) && !fs::is_directory(folder, error)) {
    throw Error("the output path is a file, not a folder", folder,
                "give " + command + " a folder as --out (it is created when missing)");
  }
  fs::create_directories(folder, error);
  if (error) throw Error("cannot create the output folder: " + error.message(), folder, "check the path and its permissions");
  const std::string lock_path = (fs::path(folder) / ".dynaguide.lock").string();
  fd_ = open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    throw Error(std::string("cannot open the output folder's lock file: ") + std::strerror(errno), lock_path,
                "check the folder is writable");
  }
  try {  // a constructor that throws runs no destructor: the lock file is closed here
    LockAndSign(fd_, lock_path, folder, command);
    removed_ = RemoveStale(folder, outputs, inputs);
  } catch (...) {
    close(fd_);
    throw;
  }
}

OutputFolderClaim::~OutputFolderClaim() {
  if (fd_ >= 0) close(fd_);  // releases the lock
}

}  // namespace dg::io
