#pragma once

#include <functional>
#include <string>

namespace dg::io {

// An exclusive advisory lock (flock) on a file, by which dynaguide processes
// take turns at something they share: an output folder, the cache of the
// default scene. It is held until the object goes or the process ends, so a
// killed holder leaves no lock behind; the file itself stays. The holder
// writes its pid into the file, so that a process refused or kept waiting
// can name it. flock conflicts between open files, so two locks on one file
// exclude each other within a process too.
class ProcessLock {
 public:
  // Opens the lock file, creating it. `fix` ends the message of every error
  // (how to get a lock file that works: another folder, a local file system).
  // @throws dg::Error naming the file when it cannot be opened.
  ProcessLock(std::string path, std::string fix);
  ~ProcessLock();
  ProcessLock(const ProcessLock&) = delete;
  ProcessLock& operator=(const ProcessLock&) = delete;

  // Takes the lock and signs it if no one holds it; false if another does.
  // @throws dg::Error when the file system cannot lock or the pid cannot be written.
  bool TryLock();
  // Takes the lock and signs it, waiting while another holds it; calls
  // on_wait(holder's pid, empty if not yet written) once before waiting.
  // @throws dg::Error as TryLock.
  void Lock(const std::function<void(const std::string& holder_pid)>& on_wait);

  // The pid the holder wrote, or empty when the file holds none yet.
  std::string HolderPid() const;

 private:
  void Sign();
  [[noreturn]] void FailToLock(int cause) const;

  std::string path_, fix_;
  int fd_ = -1;
};

}  // namespace dg::io
