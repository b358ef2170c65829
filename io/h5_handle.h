#pragma once

// RAII and error checks for the HDF5 C API, shared by io/'s HDF5 writers and
// readers. Internal to io/: it includes hdf5.h, so only .cc files include it.

#include <string>
#include <utility>

#include <hdf5.h>

#include "sim/error.h"

namespace dg::io::h5 {

inline constexpr char kWriteFix[] = "check that the directory is writable and has free space";

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

// HDF5 calls return a negative identifier or status on failure.
template <typename Status>
Status Checked(Status status, const std::string& what, const std::string& where,
               const std::string& fix = kWriteFix) {
  if (status < 0) throw Error("HDF5 could not " + what, where, fix);
  return status;
}

}  // namespace dg::io::h5
