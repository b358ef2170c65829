#include "io/process_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include "sim/error.h"

namespace dg::io {

ProcessLock::ProcessLock(std::string path, std::string fix) : path_(std::move(path)), fix_(std::move(fix)) {
  fd_ = open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw Error(std::string("cannot open the lock file: ") + std::strerror(errno), path_, fix_);
}

ProcessLock::~ProcessLock() { close(fd_); }  // releases the lock

bool ProcessLock::TryLock() {
  if (flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    if (errno == EWOULDBLOCK) return false;
    FailToLock(errno);
  }
  Sign();
  return true;
}

void ProcessLock::Lock(const std::function<void(const std::string& holder_pid)>& on_wait) {
  if (TryLock()) return;
  on_wait(HolderPid());
  while (flock(fd_, LOCK_EX) != 0) {
    if (errno != EINTR) FailToLock(errno);
  }
  Sign();
}

std::string ProcessLock::HolderPid() const {
  char text[32] = {};
  const ssize_t n = pread(fd_, text, sizeof text - 1, 0);
  std::string pid = n > 0 ? std::string(text, static_cast<size_t>(n)) : std::string();
  while (!pid.empty() && (pid.back() == '\n' || pid.back() == ' ')) pid.pop_back();
  return pid;
}

void ProcessLock::Sign() {
  const std::string pid = std::to_string(getpid()) + "\n";
  if (ftruncate(fd_, 0) != 0 || pwrite(fd_, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size())) {
    throw Error(std::string("cannot write the lock file: ") + std::strerror(errno), path_, fix_);
  }
}

void ProcessLock::FailToLock(int cause) const {
  throw Error(std::string("cannot lock the file: ") + std::strerror(cause), path_, fix_);
}

}  // namespace dg::io
