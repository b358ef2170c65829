// The cache of generated phantom scenes when processes ask for the same
// scene at once, as the processes of a test suite or a batch of runs do on
// an empty cache.
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <catch2/catch.hpp>

#include "tests/support/temporary_folder.h"
#include "tools/phantom/phantom_cache.h"
#include "tools/phantom/phantom_generator.h"
#include "tools/phantom/phantom_spec.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;

// Every file under `dir` (the lock and completion marks left out) with its contents, by relative path.
std::map<std::string, std::string> FilesUnder(const std::string& dir) {
  std::map<std::string, std::string> files;
  for (const fs::directory_entry& entry : fs::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file() || entry.path().filename() == ".complete") continue;
    std::ifstream in(entry.path(), std::ios::binary);
    files[fs::relative(entry.path(), dir).string()] = {std::istreambuf_iterator<char>(in), {}};
  }
  return files;
}

// Sets an environment variable for the test's scope.
class ScopedEnvironment {
 public:
  ScopedEnvironment(const char* name, const std::string& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    setenv(name, value.c_str(), 1);
  }
  ~ScopedEnvironment() { old_.empty() ? unsetenv(name_) : setenv(name_, old_.c_str(), 1); }

 private:
  const char* name_;
  std::string old_;
};

TEST_CASE("phantom cache: two asking at once for a scene not yet cached both get it whole", "[integration]") {
  const testing::TemporaryFolder cache("dg_phantom_cache_test");
  const ScopedEnvironment cache_dir("DG_CACHE_DIR", cache.path());
  constexpr std::uint64_t kSeed = 3;

  // flock excludes two open files of one process as it does two processes,
  // so two threads stand for two processes here.
  std::string paths[2];
  std::exception_ptr errors[2];
  {
    std::vector<std::jthread> askers;
    for (int k = 0; k < 2; ++k) {
      askers.emplace_back([&, k] {
        try {
          paths[k] = CachedPhantomScenePath("tiny", kSeed, false);
        } catch (...) {
          errors[k] = std::current_exception();
        }
      });
    }
  }  // both joined
  for (const std::exception_ptr& error : errors) {
    if (error) std::rethrow_exception(error);
  }
  REQUIRE(paths[0] == paths[1]);
  const std::string cached = fs::path(paths[0]).parent_path().string();
  CHECK(fs::exists(cached + "/.complete"));
  CHECK_FALSE(fs::exists(cached + ".partial"));

  // The truth: the same scene generated alone.
  const testing::TemporaryFolder alone("dg_phantom_cache_alone");
  phantom::PhantomSpec spec = phantom::PresetSpec("tiny");
  spec.seed = kSeed;
  phantom::GeneratePhantom(spec, alone.path(), false);
  const std::map<std::string, std::string> expected = FilesUnder(alone.path()), got = FilesUnder(cached);
  REQUIRE(expected.size() > 100);  // the scene: calibration pairs, video, CT phases, truth
  CHECK(got.size() == expected.size());
  for (const auto& [name, contents] : expected) {
    INFO(name);
    CHECK((got.contains(name) && got.at(name) == contents));
  }
}

}  // namespace
}  // namespace dg::tools
