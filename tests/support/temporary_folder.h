#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace dg::testing {

// A folder of this test process's own under the temporary directory, named
// from a stem and the process id: ctest runs test cases as concurrent processes.
// Emptied when made and removed with all it holds when destroyed, so a run leaves nothing behind.
class TemporaryFolder {
 public:
  // Two folders alive at once in one process need different stems.
  explicit TemporaryFolder(const std::string& stem)
      : path_((std::filesystem::temp_directory_path() / (stem + "_" + std::to_string(::getpid()))).string()) {
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TemporaryFolder() {
    std::error_code ignored;  // a destructor that throws would end the process; a leftover is the lesser harm
    std::filesystem::remove_all(path_, ignored);
  }
  TemporaryFolder(const TemporaryFolder&) = delete;
  TemporaryFolder& operator=(const TemporaryFolder&) = delete;

  const std::string& path() const { return path_; }
  // `name` may hold subfolders; nothing is created.
  std::string File(const std::string& name) const { return (std::filesystem::path(path_) / name).string(); }

 private:
  std::string path_;
};

}  // namespace dg::testing
