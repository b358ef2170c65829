// `dynaguide register` end to end on the tiny phantom: the fiducials tracked
// in its video (FiducialTracker, started from the truth's first-frame pixels),
// registered over one cycle and compared with the truth; the JSON holds the
// keys users script against and the YAML reads back to the same registration;
// scenes that cannot be registered are refused with a fix.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include <catch2/catch.hpp>

#include "io/registration_file.h"
#include "sim/error.h"
#include "tests/support/tiny_phantom.h"
#include "tools/register/register_run.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;
using Catch::Matchers::Contains;

// The tiny preset (160x120 video, 10 scan phases, 1.5 mm voxels), one second
// long (1.5 cycles), generated once per test process.
std::string TinyScene() { return dg::testing::TinyPhantomDir() + "/scene.yaml"; }

std::string Text(const std::string& path) {
  std::stringstream text;
  text << std::ifstream(path).rdbuf();
  return text.str();
}

double JsonNumber(const std::string& json, const std::string& key) {
  std::smatch match;
  REQUIRE(std::regex_search(json, match, std::regex("\"" + key + R"(\": ([-+0-9.eE]+))")));
  return std::stod(match[1]);
}

TEST_CASE("register tool: tracked fiducials register the tiny phantom over one cycle", "[tools][integration]") {
  RegisterRunOptions options;
  options.scene = TinyScene();
  options.cycles = 1;
  const RegisterRunSummary summary = RunRegister(options);
  const io::Registration& r = summary.result.registration;
  REQUIRE(summary.error);
  WARN(RegisterReport(summary));
  // A gross-failure check only (the accuracy figures are the default
  // phantom's, tests/stages/register): one cycle of the tiny 160x120 video
  // measured 0.95 deg, 0.71 mm and +19 ms; a wrong basin of the shift search
  // would be a scan phase (67 ms) or more off, a wrong correspondence degrees.
  CHECK(summary.error->rotation_deg < 2);
  CHECK(summary.error->translation_mm < 2);
  CHECK(std::abs(summary.error->phase_shift_ms) < 33);  // half a scan phase
  CHECK(summary.frames == 20);  // one period at 30 fps
  CHECK(summary.fiducials == 6);
  CHECK(r.cycles == Approx(1.0).epsilon(1e-6));

  const fs::path dir = fs::path(TinyScene()).parent_path();
  const std::string json_path = (dir / "registration.json").string(), yaml_path = (dir / "registration.yaml").string();
  WriteRegisterJson(json_path, summary);
  const std::string json = Text(json_path);
  std::smatch matrix;
  REQUIRE(std::regex_search(json, matrix, std::regex(R"("T_C_S": \[([^\]]*)\])")));
  std::stringstream values(std::regex_replace(matrix[1].str(), std::regex(","), " "));
  for (int k = 0; k < 16; ++k) {
    double value;
    REQUIRE(values >> value);
    CHECK(value == r.T_C_S(k / 4, k % 4));  // row-major, all digits
  }
  CHECK(JsonNumber(json, "phase_shift_s") == Approx(r.phase_shift_s));
  CHECK(JsonNumber(json, "residual_px_left") == Approx(r.left.mean_px));
  CHECK(JsonNumber(json, "residual_px_right") == Approx(r.right.mean_px));
  CHECK(JsonNumber(json, "residual_mm_left") == Approx(r.left.mean_mm));
  CHECK(JsonNumber(json, "residual_mm_right") == Approx(r.right.mean_mm));
  CHECK(JsonNumber(json, "cycles") == Approx(1.0));

  io::WriteRegistrationYaml(yaml_path, r);
  const io::Registration back = io::ReadRegistrationYaml(yaml_path);
  CHECK(back.T_C_S == r.T_C_S);
  CHECK(back.phase_shift_s == r.phase_shift_s);
  CHECK(back.left.mean_mm == Approx(r.left.mean_mm));
}

TEST_CASE("register tool: scenes that cannot be registered are refused with a fix", "[tools][integration]") {
  const fs::path dir = fs::path(TinyScene()).parent_path();
  RegisterRunOptions options;
  SECTION("no truth and no first-frame pixels") {
    const std::string text = std::regex_replace(Text(TinyScene()), std::regex("\ntruth:[^\n]*"), "");
    const std::string scene = (dir / "no_truth.yaml").string();
    std::ofstream(scene) << text;
    options.scene = scene;
    CHECK_THROWS_WITH(RunRegister(options), Contains("first-frame pixels are not known") && Contains("--fiducials-uv"));
  }
  // A first-frame pixel file of this text, refused with this message.
  auto refuses_pixels = [&](const std::string& text, const std::string& message) {
    const std::string uv = (dir / "pixels.csv").string();
    std::ofstream(uv) << text;
    options.scene = TinyScene();
    options.fiducials_uv = uv;
    CHECK_THROWS_WITH(RunRegister(options), Contains(message));
  };
  SECTION("first-frame pixels for another number of fiducials") {
    refuses_pixels("# u, v\n80.5, 60\n90, 61.25\n", "2 first-frame pixels for 6 scan fiducials");
  }
  SECTION("a malformed pixel line") { refuses_pixels("80.5, 60\n90 x\n", "pixels.csv:2"); }
  SECTION("beads from the CT without saying which marker is which") {
    options.scene = TinyScene();
    options.ct_beads = true;
    CHECK_THROWS_WITH(RunRegister(options), Contains("found 6 beads in the CT") && Contains("in this order"));
  }
  SECTION("a window longer than the video") {
    options.scene = TinyScene();
    options.cycles = 2;  // the video holds 1.5
    CHECK_THROWS_WITH(RunRegister(options), Contains("the video holds") && Contains("--cycles asks for 2"));
  }
  SECTION("the scene's window, without --cycles, longer than the video") {
    const std::string text = std::regex_replace(Text(TinyScene()), std::regex("registration:\n  cycles: [0-9.]+"),
                                                "registration:\n  cycles: 2");
    REQUIRE(text.find("registration:\n  cycles: 2") != std::string::npos);
    const std::string scene = (dir / "two_cycles.yaml").string();
    std::ofstream(scene) << text;
    options.scene = scene;
    CHECK_THROWS_WITH(RunRegister(options), Contains("the video holds") && Contains("registration.cycles asks for 2"));
  }
}

}  // namespace
}  // namespace dg::tools
