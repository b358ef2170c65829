#include "io/output_folder.h"

#include <algorithm>
#include <filesystem>
#include <string>

#include "sim/error.h"

namespace dg::io {

namespace fs = std::filesystem;

bool MatchesOutputName(const std::string& name, const std::string& pattern) {
  const size_t star = pattern.find('*');
  if (star == std::string::npos) return name == pattern;
  const std::string head = pattern.substr(0, star), tail = pattern.substr(star + 1);
  return name.size() >= head.size() + tail.size() && name.compare(0, head.size(), head) == 0 &&
         name.compare(name.size() - tail.size(), tail.size(), tail) == 0;
}

namespace {

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
  lock_ = std::make_unique<ProcessLock>((fs::path(folder) / ".dynaguide.lock").string(),
                                        "check the folder is writable and on a file system that supports flock, or give " +
                                            command + " another --out");
  if (!lock_->TryLock()) {
    const std::string pid = lock_->HolderPid();
    throw Error("the output folder is in use by another dynaguide process" + (pid.empty() ? "" : " (pid " + pid + ")"),
                folder, "wait for it to finish, or give " + command + " another --out");
  }
  removed_ = RemoveStale(folder, outputs, inputs);
}

OutputFolderClaim::~OutputFolderClaim() = default;

}  // namespace dg::io
