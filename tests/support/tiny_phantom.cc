#include "tests/support/tiny_phantom.h"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>

#include "tools/phantom/phantom_generator.h"
#include "tools/phantom/phantom_spec.h"

namespace dg::testing {
namespace {

namespace fs = std::filesystem;

struct TemporaryPhantom {
  std::string dir = (fs::temp_directory_path() / ("dg_tiny_phantom_" + std::to_string(::getpid()))).string();
  TemporaryPhantom() {
    fs::remove_all(dir);
    // Under ctest the fixture tiny_phantom (tests/CMakeLists.txt) has generated
    // the scene once for the whole run: a copy is this process's to write into.
    const char* shared = std::getenv("DG_TINY_PHANTOM_DIR");
    if (shared != nullptr && *shared != '\0') {
      fs::copy(shared, dir, fs::copy_options::recursive);
    } else {
      tools::phantom::GeneratePhantom(tools::phantom::PresetSpec("tiny"), dir, false);
    }
  }
  ~TemporaryPhantom() { fs::remove_all(dir); }
};

}  // namespace

const std::string& TinyPhantomDir() {
  static const TemporaryPhantom phantom;
  return phantom.dir;
}

}  // namespace dg::testing
