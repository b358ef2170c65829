#pragma once

// RAII and error checks for the HDF5 C API, shared by io/'s HDF5 writers and
// readers. Internal to io/: it includes hdf5.h, so only .cc files include it.

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <string>
#include <utility>

#include <hdf5.h>

#include "sim/error.h"

namespace dg::io::h5 {

inline constexpr char kWriteFix[] = "check that the directory is writable and has free space";
// When the operating system refused a write for want of space (ENOSPC, EFBIG, EDQUOT).
inline constexpr char kSpaceFix[] = "free space on the output's file system or choose another --out";

// HDF5 prints its whole error stack to stderr on every failure unless told
// not to, and in a thread-safe build (Debian's is one) that setting belongs to
// each thread's own error stack: every thread that calls HDF5 silences it
// once, before its first call. Failures reach the user as one dg::Error
// (Checked) instead. Each entry point of io/'s HDF5 code calls this.
inline void Quiet() {
  thread_local const bool quiet = H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr) >= 0;
  (void)quiet;
}

// Why the last HDF5 call on this thread failed: the innermost entry of its
// error stack, where HDF5 first saw the failure. For a failed system call that
// is the operating system's message ("No space left on device", "File too
// large"), with its errno; otherwise HDF5's own description.
struct Cause {
  std::string text;
  int os_errno = 0;
};

inline Cause InnermostCause() {
  Cause cause;
  const auto innermost = [](unsigned n, const H5E_error2_t* error, void* data) -> herr_t {
    if (n != 0 || error->desc == nullptr) return 0;
    auto* found = static_cast<Cause*>(data);
    const std::string desc = error->desc;
    // HDF5 words a failed system call as "..., errno = 28, error message = '...', ...".
    if (const size_t at = desc.find("errno = "); at != std::string::npos) {
      found->os_errno = std::atoi(desc.c_str() + at + 8);
    }
    found->text = found->os_errno > 0 ? std::strerror(found->os_errno) : desc;
    return 0;
  };
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, innermost, &cause);
  return cause;
}

inline bool OutOfSpace(int os_errno) { return os_errno == ENOSPC || os_errno == EFBIG || os_errno == EDQUOT; }

// Closes an HDF5 identifier at the end of its scope.
class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(Handle&& other) noexcept : id_(std::exchange(other.id_, -1)), close_(other.close_) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

// HDF5 calls return a negative identifier or status on failure: that becomes
// one dg::Error with HDF5's innermost cause, and the fix for a full disk when
// the operating system refused a write for want of space.
template <typename Status>
Status Checked(Status status, const std::string& what, const std::string& where,
               const std::string& fix = kWriteFix) {
  if (status >= 0) return status;
  const Cause cause = InnermostCause();
  throw Error("HDF5 could not " + what + (cause.text.empty() ? "" : ": " + cause.text), where,
              OutOfSpace(cause.os_errno) ? kSpaceFix : fix);
}

// Object creation properties without modification times: HDF5 stamps each
// object with the clock by default, so the same data would give different bytes.
inline Handle Untimed(hid_t property_class, const std::string& where) {
  Handle properties(Checked(H5Pcreate(property_class), "create properties", where), H5Pclose);
  Checked(H5Pset_obj_track_times(properties.get(), 0), "set properties", where);
  return properties;
}

// Room for what HDF5 adds to a file beside the data of one write: object
// headers, a global heap collection (4 KiB) for a string, B-tree nodes.
inline constexpr hsize_t kMetadataBytes = 16 * 1024;

// Allocates `bytes` past the file's allocated end (HDF5's EOA) before HDF5
// writes them. HDF5 updates a file in place and cannot undo a write that
// failed halfway: a flush that runs out of space leaves a superblock pointing
// past the end of the file, which then no longer opens, and a file that cannot
// be closed. Space that is already allocated cannot run out, so a full disk
// (ENOSPC) or a file size limit (EFBIG) fails here, before a byte is written,
// and the file stays as its last flush left it. The allocation beyond the EOA
// is trimmed when the file closes (CloseFile).
// @throws dg::Error naming `where` and the operating system's reason.
inline void ReserveSpace(hid_t file, hsize_t bytes, const std::string& where) {
  haddr_t allocated_end = 0;
  void* handle = nullptr;
  Checked(H5Fget_eoa(file, &allocated_end), "get the allocated size", where);
  Checked(H5Fget_vfd_handle(file, H5P_DEFAULT, &handle), "get the file descriptor", where);
  const int fd = *static_cast<int*>(handle);  // the default (sec2) driver's handle
  struct stat status {};
  if (fstat(fd, &status) != 0) throw Error(std::string("cannot stat the file: ") + std::strerror(errno), where, kWriteFix);
  const auto size = static_cast<hsize_t>(status.st_size);
  if (size >= allocated_end + bytes) return;
  const int error = posix_fallocate(fd, static_cast<off_t>(size), static_cast<off_t>(allocated_end + bytes - size));
  if (error != 0) {
    throw Error("cannot write " + std::to_string(bytes / 1024 + 1) + " KiB more: " + std::strerror(error), where,
                OutOfSpace(error) ? kSpaceFix : kWriteFix);
  }
}

// Closes a file that io/ created and trims what ReserveSpace allocated past
// its end. @return empty, or why HDF5 could not close it (for a destructor to log).
inline std::string CloseFile(hid_t file, const std::string& path) {
  haddr_t allocated_end = 0;
  const bool known = H5Fget_eoa(file, &allocated_end) >= 0;
  // Trimmed only when this was the file's last identifier (an H5Table opens it twice).
  const bool last = H5Fget_obj_count(file, H5F_OBJ_FILE) == 1;
  if (H5Fclose(file) < 0) {
    const Cause cause = InnermostCause();
    return "HDF5 could not close " + path + ": " + (cause.text.empty() ? "unknown cause" : cause.text);
  }
  struct stat status {};
  if (known && last && stat(path.c_str(), &status) == 0 && static_cast<haddr_t>(status.st_size) > allocated_end) {
    (void)truncate(path.c_str(), static_cast<off_t>(allocated_end));  // only unused space: a failure costs nothing
  }
  return {};
}

}  // namespace dg::io::h5
