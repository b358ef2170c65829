// Input files that are not what they claim to be: each gets a named error
// from the reader before anything hangs or floods the terminal (a FIFO would
// block, /dev/zero would be read for ever, a binary file would be parsed into
// messages of raw control bytes).
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>

#include <catch2/catch.hpp>

#include "io/gmsh_reader.h"
#include "io/input_file.h"
#include "io/registration_file.h"
#include "io/scene.h"
#include "io/sim_problem.h"
#include "sim/error.h"
#include "tests/support/temporary_folder.h"

namespace dg::io {
namespace {

namespace fs = std::filesystem;
using Catch::Matchers::Contains;

// A folder of bad inputs: a binary file and a FIFO (the folder is the directory).
struct BadInputs {
  const testing::TemporaryFolder temporary{"dg_faults_input"};
  const fs::path folder = temporary.path(), binary = folder / "binary.yaml", fifo = folder / "pipe.yaml";
  BadInputs() {
    std::ofstream(binary, std::ios::binary) << std::string("ok: 1\n") + std::string("\x7f" "ELF\0\x02\x01", 7) + "rest";
    REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  }
};

// The message of the dg::Error `read` throws ("" when it throws none).
template <typename Read>
std::string ErrorOf(Read read) {
  try {
    read();
  } catch (const Error& e) {
    return e.what();
  }
  return {};
}

TEST_CASE("bad input: a binary file as a scene, problem or registration is named as not text, with line and byte",
          "[faults][unit]") {
  const BadInputs inputs;
  const std::string binary = inputs.binary.string();
  const std::pair<std::string, std::string> cases[] = {
      {"scene file", ErrorOf([&] { ReadScene(binary); })},
      {"problem file", ErrorOf([&] { ReadSimProblem(binary); })},
      {"registration file", ErrorOf([&] { ReadRegistrationYaml(binary); })},
      {"fiducial pixel file", ErrorOf([&] { ReadFiducialPixels(binary); })},
  };
  for (const auto& [what, message] : cases) {
    INFO(message);
    CHECK_THAT(message, Contains("the " + what + " is not a text file"));
    CHECK_THAT(message, Contains(binary + ":2 (byte 0x7f at offset 6)"));
    CHECK_THAT(message, Contains("not a binary file"));
  }
}

TEST_CASE("bad input: a binary file as a mesh is named as not a Gmsh file at its first line", "[faults][unit]") {
  const BadInputs inputs;
  const fs::path mesh = inputs.folder / "binary.msh";
  std::ofstream(mesh, std::ios::binary) << std::string("\x7f" "ELF\x02\x01\x01\0\0\0", 10) << std::string(1000, 'x');
  REQUIRE_THROWS_WITH(ReadGmsh(mesh.string(), 1.0),
                      Contains("not a Gmsh .msh file (its first line is not text)") && Contains(mesh.string() + ":1"));
  // A file with no line end in its first 256 bytes (here 1000 letters) is no .msh either.
  const fs::path one_line = inputs.folder / "one_line.msh";
  std::ofstream(one_line) << std::string(1000, 'x');
  REQUIRE_THROWS_WITH(ReadGmsh(one_line.string(), 1.0), Contains("not a Gmsh .msh file"));
}

TEST_CASE("bad input: a FIFO, a device and a directory are refused before they are read", "[faults][unit]") {
  const BadInputs inputs;
  // The FIFO has no writer: opening it for reading would block this test for ever.
  REQUIRE_THROWS_WITH(ReadScene(inputs.fifo.string()), Contains("scene file is a FIFO (named pipe), not a file"));
  REQUIRE_THROWS_WITH(ReadGmsh("/dev/zero", 1.0), Contains("mesh file is a character device, not a file"));
  REQUIRE_THROWS_WITH(ReadSimProblem(inputs.folder.string()), Contains("problem file is a directory, not a file"));
  REQUIRE_THROWS_WITH(ReadScene((inputs.folder / "missing.yaml").string()),
                      Contains("scene file does not exist") && Contains("dynaguide phantom writes one"));
  REQUIRE(FirstBinaryByte("a\tb\r\nc", 6) == 6);
}

// A flat (zero-volume) tetrahedron is named as the user finds it in the file:
// its element tag and line, not the reader's 0-based index (here 1), in both
// formats. Node and element tags are sparse, as Gmsh writes them after edits.
TEST_CASE("bad input: a flat tetrahedron is named by the file's element tag and line", "[faults][unit]") {
  const BadInputs inputs;
  struct Case {
    std::string name, text;
    int line;
  };
  const Case cases[] = {
      {"flat_v22.msh",
       "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n5\n11 0 0 0\n12 1 0 0\n13 0 1 0\n14 0 0 1\n15 1 1 0\n"
       "$EndNodes\n$Elements\n2\n5 4 2 1 1 11 12 13 14\n9 4 2 1 1 12 13 15 11\n$EndElements\n",
       15},
      {"flat_v41.msh",
       "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 5 11 15\n3 1 0 5\n11\n12\n13\n14\n15\n0 0 0\n1 0 0\n0 1 0\n"
       "0 0 1\n1 1 0\n$EndNodes\n$Elements\n1 2 5 9\n3 1 4 2\n5 11 12 13 14\n9 12 13 15 11\n$EndElements\n",
       22},
  };
  for (const Case& c : cases) {
    INFO(c.name);
    const std::string path = (inputs.folder / c.name).string();
    std::ofstream(path) << c.text;
    std::string where;
    try {
      ReadGmsh(path, 1.0);
    } catch (const Error& error) {
      CHECK_THAT(error.problem(), Contains("degenerate element (volume"));
      where = error.where();
    }
    CHECK(where == path + ":" + std::to_string(c.line) + ", element 9");
  }
}

// yaml-cpp keeps the first of two equal keys and drops the second silently.
TEST_CASE("bad input: a key given twice in a scene is an error naming the second line", "[faults][unit]") {
  const BadInputs inputs;
  const fs::path scene = inputs.folder / "twice.yaml";
  std::ofstream(scene) << "name: x\nmesh:\n  units: mm\n  file: mesh.msh\n  units: m\n";
  REQUIRE_THROWS_WITH(ReadScene(scene.string()), Contains("key 'units' appears twice") &&
                                                     Contains(scene.string() + ":5 (mesh.units)") &&
                                                     Contains("keep one of the two 'units:' lines"));
}

}  // namespace
}  // namespace dg::io
