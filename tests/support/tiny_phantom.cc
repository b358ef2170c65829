#include "tests/support/tiny_phantom.h"

#include <cstdlib>
#include <filesystem>

#include "tests/support/temporary_folder.h"
#include "tools/phantom/phantom_generator.h"
#include "tools/phantom/phantom_spec.h"

namespace dg::testing {
namespace {

struct TemporaryPhantom {
  TemporaryFolder folder{"dg_tiny_phantom"};
  TemporaryPhantom() {
    // Under ctest the fixture tiny_phantom (tests/CMakeLists.txt) has generated
    // the scene once for the whole run: a copy is this process's to write into.
    const char* shared = std::getenv("DG_TINY_PHANTOM_DIR");
    if (shared != nullptr && *shared != '\0') {
      std::filesystem::copy(shared, folder.path(), std::filesystem::copy_options::recursive);
    } else {
      tools::phantom::GeneratePhantom(tools::phantom::PresetSpec("tiny"), folder.path(), false);
    }
  }
};

}  // namespace

const std::string& TinyPhantomDir() {
  static const TemporaryPhantom phantom;
  return phantom.folder.path();
}

}  // namespace dg::testing
