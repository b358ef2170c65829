// A run owns its output folder: a second writer is refused naming the
// holder's pid, and an earlier run's files are removed before a new run
// writes, never mixed with its own (io::OutputFolderClaim).
#include "io/output_folder.h"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <catch2/catch.hpp>

#include "pipeline/run_scene.h"
#include "tests/support/temporary_folder.h"
#include "tests/support/tiny_phantom.h"

namespace dg::io {
namespace {

namespace fs = std::filesystem;
using Catch::Matchers::Contains;

void WriteText(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

std::string ReadText(const fs::path& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST_CASE("output folder: a second claim is refused naming the holder's pid, and allowed once released",
          "[faults][unit]") {
  const testing::TemporaryFolder temporary("dg_faults_claim");
  const std::string folder = temporary.File("out");  // not there yet: the claim makes it
  const std::string pid = std::to_string(getpid());
  {
    const OutputFolderClaim first(folder, "dynaguide run", {"run.h5"});
    REQUIRE(fs::is_directory(folder));
    // flock conflicts between open files, so a second claim in this process stands for another process.
    REQUIRE_THROWS_WITH(OutputFolderClaim(folder, "dynaguide run", {"run.h5"}),
                        Contains("in use by another dynaguide process (pid " + pid + ")") &&
                            Contains("give dynaguide run another --out"));
  }
  REQUIRE_NOTHROW(OutputFolderClaim(folder, "dynaguide run", {"run.h5"}));
  // --out naming a file: a named error, and the file is left alone.
  const std::string file = folder + "/notes.txt";
  WriteText(file, "mine");
  REQUIRE_THROWS_WITH(OutputFolderClaim(file, "dynaguide sim", {"sim.h5"}),
                      Contains("the output path is a file, not a folder") && Contains("give dynaguide sim a folder"));
  REQUIRE(ReadText(file) == "mine");
}

TEST_CASE("output folder: an earlier run's outputs are removed; other files and the run's inputs are kept",
          "[faults][unit]") {
  const testing::TemporaryFolder temporary("dg_faults_stale");
  const fs::path folder = temporary.path();
  for (const char* name : {"run.h5", "run.h5.part", "composite_00003.png", "annotated.avi", "registration.yaml",
                           "notes.txt", "composite.txt"}) {
    WriteText(folder / name, "earlier");
  }
  const OutputFolderClaim claim(folder.string(), "dynaguide run", pipeline::RunOutputNames(),
                                {(folder / "registration.yaml").string()});
  std::vector<std::string> removed = claim.removed();
  std::sort(removed.begin(), removed.end());
  REQUIRE(removed == std::vector<std::string>{"annotated.avi", "composite_00003.png", "run.h5", "run.h5.part"});
  for (const char* kept : {"registration.yaml", "notes.txt", "composite.txt"}) REQUIRE(fs::exists(folder / kept));
  REQUIRE(MatchesOutputName("composite_00012.png", "composite_*.png"));
  REQUIRE_FALSE(MatchesOutputName("composite_00012.jpg", "composite_*.png"));
}

// While another process holds the folder, `dynaguide run` into it stops
// before writing anything, and the holder's log is left as it was.
TEST_CASE("output folder: a run into a folder in use is refused and leaves the holder's files untouched",
          "[faults][integration]") {
  const testing::TemporaryFolder temporary("dg_faults_busy");
  const fs::path folder = temporary.File("out");
  const OutputFolderClaim holder(folder.string(), "dynaguide run", pipeline::RunOutputNames());
  WriteText(folder / "run.h5.part", "the holder's log");
  pipeline::RunOptions options;
  options.scene = dg::testing::TinyPhantomDir() + "/scene.yaml";
  options.out_dir = folder.string();
  options.video = false;
  options.progress = false;
  REQUIRE_THROWS_WITH(pipeline::RunScene(options), Contains("in use by another dynaguide process (pid " +
                                                         std::to_string(getpid()) + ")"));
  REQUIRE(ReadText(folder / "run.h5.part") == "the holder's log");
  REQUIRE_FALSE(fs::exists(folder / "run.h5"));
}

}  // namespace
}  // namespace dg::io
