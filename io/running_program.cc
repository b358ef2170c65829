#include "io/running_program.h"

#include <system_error>

#include "sim/error.h"

namespace dg::io {

std::filesystem::path RunningProgramFolder() {
  std::error_code error;
  const std::filesystem::path running = std::filesystem::read_symlink("/proc/self/exe", error);
  if (error) {
    throw Error("cannot find the running executable's path: " + error.message(), "/proc/self/exe",
                "mount /proc (Linux)");
  }
  return running.parent_path();
}

}  // namespace dg::io
