#include "io/scene.h"

#include <filesystem>
#include <fstream>

#include <catch2/catch.hpp>

#include "sim/error.h"
#include "tests/support/temporary_folder.h"

namespace dg::io {
namespace {

namespace fs = std::filesystem;

constexpr char kScene[] = R"(name: test
mesh:
  file: mesh.msh
  units: mm
  fixed_set: base
material:
  youngs_modulus_pa: 5000
preoperative:
  period_s: 0.8
  phases: 3
  motion: scan.h5
  ct: ct/phase_%02d.mhd
overlays:
  surface_mesh: assets/skin.obj
  internal_meshes: [assets/a.obj]
  internal_points: scan.h5:/points
calibration: calibration.yaml
video:
  left: video/left.avi
  right: video/right.avi
  fps: 30
truth: truth.h5
)";

// Empties `folder` and makes it a scene directory: scene.yaml holding `text`, and an empty file for every name
// kScene uses.
fs::path MakeSceneDir(const testing::TemporaryFolder& folder, const std::string& text) {
  const fs::path dir = folder.path();
  fs::remove_all(dir);
  for (const char* file : {"mesh.msh", "scan.h5", "ct/phase_00.mhd", "ct/phase_01.mhd", "ct/phase_02.mhd",
                           "assets/skin.obj", "assets/a.obj", "calibration.yaml", "video/left.avi",
                           "video/right.avi", "truth.h5"}) {
    fs::create_directories((dir / file).parent_path());
    std::ofstream(dir / file) << "";
  }
  std::ofstream(dir / "scene.yaml") << text;
  return dir;
}

}  // namespace

// Every path resolves against the scene file; units and optional parts are read.
TEST_CASE("scene: paths resolve against the scene file", "[io][unit]") {
  const testing::TemporaryFolder folder("dg_scene_test_ok");
  const fs::path dir = MakeSceneDir(folder, kScene);
  const Scene scene = ReadScene((dir / "scene.yaml").string());
  REQUIRE(scene.name == "test");
  REQUIRE(scene.mesh.file == (dir / "mesh.msh").string());
  REQUIRE(scene.mesh.metres_per_unit == 1e-3);
  REQUIRE(scene.material.youngs_modulus_pa == 5000);
  REQUIRE(scene.material.poissons_ratio == 0.45);  // the default
  REQUIRE(scene.preoperative->ct_volumes.size() == 3);
  REQUIRE(scene.preoperative->ct_volumes[2] == (dir / "ct/phase_02.mhd").string());
  REQUIRE(scene.overlays->internal_points == (dir / "scan.h5").string() + ":/points");
  REQUIRE(scene.video.fps == 30);
  REQUIRE(scene.truth == (dir / "truth.h5").string());
  REQUIRE(scene.text == kScene);
}

// An unknown key, a wrong type and a missing file are errors naming the key path.
TEST_CASE("scene: bad scenes give named errors", "[io][unit]") {
  const testing::TemporaryFolder folder("dg_scene_test_bad");
  std::string text = kScene;
  text.replace(text.find("  fps: 30"), 9, "  fps: 30\n  rate: 30");
  fs::path dir = MakeSceneDir(folder, text);
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()),
                      Catch::Contains("unknown key 'rate'") && Catch::Contains("video.rate") &&
                          Catch::Contains("scene.yaml:22"));

  text = kScene;
  text.replace(text.find("fps: 30"), 7, "fps: fast");
  dir = MakeSceneDir(folder, text);
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()), Catch::Contains("'fps' must be a number"));

  dir = MakeSceneDir(folder, kScene);
  fs::remove(dir / "video/right.avi");
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()),
                      Catch::Contains("file not found") && Catch::Contains("video/right.avi") &&
                          Catch::Contains("video.right"));

  text = kScene;
  text.replace(text.find("ct/phase_%02d.mhd"), 17, "ct/%s.mhd");
  dir = MakeSceneDir(folder, text);
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()), Catch::Contains("one integer field"));
}

// overlays: units covers its meshes and points (absent: metres); an unknown
// unit and a mesh file of no format read are refused at load, naming the key.
TEST_CASE("scene: overlay units and mesh formats", "[io][unit]") {
  const testing::TemporaryFolder folder("dg_scene_test_overlays");
  fs::path dir = MakeSceneDir(folder, kScene);
  REQUIRE(ReadScene((dir / "scene.yaml").string()).overlays->metres_per_unit == 1.0);

  std::string text = kScene;
  text.replace(text.find("overlays:\n"), 10, "overlays:\n  units: mm\n");
  dir = MakeSceneDir(folder, text);
  REQUIRE(ReadScene((dir / "scene.yaml").string()).overlays->metres_per_unit == 1e-3);

  text = kScene;
  text.replace(text.find("overlays:\n"), 10, "overlays:\n  units: inch\n");
  dir = MakeSceneDir(folder, text);
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()),
                      Catch::Contains("unknown length unit 'inch'") && Catch::Contains("overlays.units"));

  text = kScene;
  text.replace(text.find("assets/a.obj"), 12, "assets/a.off");
  dir = MakeSceneDir(folder, text);
  std::ofstream(dir / "assets/a.off") << "";
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()),
                      Catch::Contains("not a surface mesh format read") && Catch::Contains("overlays.internal_meshes") &&
                          Catch::Contains(".obj, .ply, .stl, .vtk or .vtp"));
}

// The recording's layout: side by side needs no right file; image sequences
// are patterns, not files; a misspelt layout is named with the choices.
TEST_CASE("scene: video layouts", "[io][unit]") {
  const testing::TemporaryFolder folder("dg_scene_test_layout");
  std::string text = kScene;
  text.replace(text.find("  right: video/right.avi\n"), 25, "  layout: side_by_side\n  rectified: true\n");
  fs::path dir = MakeSceneDir(folder, text);
  Scene scene = ReadScene((dir / "scene.yaml").string());
  REQUIRE(scene.video.layout == Scene::Video::Layout::kSideBySide);
  REQUIRE(scene.video.right.empty());
  REQUIRE(scene.video.rectified);

  text = kScene;
  text.replace(text.find("  left: video/left.avi\n  right: video/right.avi\n"), 48,
               "  layout: image_sequences\n  left: frames/left_%04d.png\n  right: frames/right_*.png\n");
  dir = MakeSceneDir(folder, text);
  scene = ReadScene((dir / "scene.yaml").string());
  REQUIRE(scene.video.layout == Scene::Video::Layout::kImageSequences);
  REQUIRE(scene.video.left == (dir / "frames/left_%04d.png").string());
  REQUIRE_FALSE(scene.video.rectified);

  text = kScene;
  text.replace(text.find("  fps: 30"), 9, "  fps: 30\n  layout: stacked");
  dir = MakeSceneDir(folder, text);
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()),
                      Catch::Contains("unknown video layout 'stacked'") && Catch::Contains("video.layout") &&
                          Catch::Contains("side_by_side"));

  text = kScene;
  text.replace(text.find("  fps: 30"), 9, "  fps: 30\n  rectified: maybe");
  dir = MakeSceneDir(folder, text);
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()), Catch::Contains("'rectified' must be true or false"));
}

// The simulation and registration blocks: defaults, values, and named errors.
TEST_CASE("scene: simulation and registration", "[io][unit]") {
  const testing::TemporaryFolder folder("dg_scene_test_sim");
  std::string text = kScene;
  text += "simulation:\n  mode: volume\n  dt_s: 1.0e-4\n  concurrent: false\nregistration:\n  cycles: 2\n";
  fs::path dir = MakeSceneDir(folder, text);
  Scene scene = ReadScene((dir / "scene.yaml").string());
  REQUIRE(scene.simulation->mode == sim::SimulationMode::kVolume);
  REQUIRE(scene.simulation->dt_s == 1e-4);
  REQUIRE_FALSE(scene.simulation->concurrent);
  REQUIRE(scene.simulation->damping_per_s == 75);  // the paper's alpha by default
  REQUIRE(scene.simulation->precision == sim::Precision::kFloat);
  REQUIRE(scene.simulation->inverse_interval_steps == sim::kDefaultInverseIntervalSteps);
  REQUIRE(scene.registration->cycles == 2);
  REQUIRE(scene.registration->file.empty());

  dir = MakeSceneDir(folder, kScene + std::string("registration:\n  file: registration.yaml\n"));
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()),
                      Catch::Contains("file not found") && Catch::Contains("registration.file"));
  std::ofstream(dir / "registration.yaml") << "";
  scene = ReadScene((dir / "scene.yaml").string());
  REQUIRE(scene.registration->file == (dir / "registration.yaml").string());
  REQUIRE_FALSE(scene.simulation);

  dir = MakeSceneDir(folder, kScene + std::string("simulation:\n  mode: rigid\n"));
  // A bad mode or precision: the file, the key, the value and the values allowed.
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()),
                      Catch::Contains("unknown simulation mode 'rigid'") && Catch::Contains("simulation.mode") &&
                          Catch::Contains((dir / "scene.yaml").string()) &&
                          Catch::Contains("surface, volume or combined"));
  dir = MakeSceneDir(folder, kScene + std::string("simulation:\n  precision: half\n"));
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()),
                      Catch::Contains("unknown precision 'half'") && Catch::Contains("simulation.precision") &&
                          Catch::Contains((dir / "scene.yaml").string()) && Catch::Contains("float") &&
                          Catch::Contains("or double"));
  // The names scene files use are the enums' own.
  for (sim::SimulationMode mode :
       {sim::SimulationMode::kSurface, sim::SimulationMode::kVolume, sim::SimulationMode::kCombined}) {
    for (sim::Precision precision : {sim::Precision::kFloat, sim::Precision::kDouble}) {
      dir = MakeSceneDir(folder, kScene + std::string("simulation:\n  mode: ") + sim::ToString(mode) +
                                     "\n  precision: " + sim::ToString(precision) + "\n");
      scene = ReadScene((dir / "scene.yaml").string());
      CHECK(scene.simulation->mode == mode);
      CHECK(scene.simulation->precision == precision);
    }
  }
  dir = MakeSceneDir(folder, kScene + std::string("simulation:\n  time_step_policy: shrink\n"));
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()),
                      Catch::Contains("unknown time step policy 'shrink'") &&
                          Catch::Contains("simulation.time_step_policy") && Catch::Contains("substep"));
  dir = MakeSceneDir(folder, kScene + std::string("simulation:\n  inverse_interval_steps: 0\n"));
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()),
                      Catch::Contains("'inverse_interval_steps' must lie in [1, 50]") &&
                          Catch::Contains("simulation.inverse_interval_steps"));
  dir = MakeSceneDir(folder, kScene + std::string("simulation:\n  dt: 2e-4\n"));
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()), Catch::Contains("simulation.dt"));
  dir = MakeSceneDir(folder, kScene + std::string("registration:\n  cycles: 0.5\n"));
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()), Catch::Contains("registration.cycles"));

  // Forces recovered from the scan's motion need the scan.
  text = kScene;
  text.erase(text.find("preoperative:"), text.find("overlays:") - text.find("preoperative:"));
  dir = MakeSceneDir(folder, text + "simulation:\n  mode: combined\n");
  REQUIRE_THROWS_WITH(ReadScene((dir / "scene.yaml").string()), Catch::Contains("needs the scan's motion"));
}

}  // namespace dg::io
