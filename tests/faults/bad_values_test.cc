// Values a user gets wrong that used to pass unnoticed or end in an
// "unexpected error": each is refused with what, where and a fix.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <catch2/catch.hpp>

#include "io/calibration.h"
#include "io/gmsh_mesher.h"
#include "io/gmsh_reader.h"
#include "io/scene.h"
#include "sim/error.h"
#include "sim/stability.h"
#include "stages/image_sequence.h"
#include "tests/support/h5_plain.h"
#include "tests/support/tiny_phantom.h"
#include "tools/run/run_job.h"

namespace dg {
namespace {

namespace fs = std::filesystem;
using Catch::Matchers::Contains;

fs::path FreshFolder(const std::string& name) {
  const fs::path folder = fs::temp_directory_path() / ("dg_faults_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(folder);
  fs::create_directories(folder);
  return folder;
}

// A run of the tiny phantom's scene as `text` gives it (written beside the
// scene as scene_NAME.yaml) into a fresh folder, without video or progress.
tools::RunOptions VariantRun(const std::string& name, const std::string& text) {
  const std::string path = dg::testing::TinyPhantomDir() + "/scene_" + name + ".yaml";
  std::ofstream(path) << text;
  tools::RunOptions options;
  options.scene = path;
  options.out_dir = FreshFolder(name).string();
  options.video = false;
  options.progress = false;
  return options;
}

// The tiny phantom's calibration (baseline a few millimetres, T in metres)
// written again with T in millimetres, as a target measured in millimetres
// makes OpenCV give it, and with T zero.
TEST_CASE("bad values: a calibration's T in millimetres or zero is refused, naming the unit", "[faults][unit]") {
  const fs::path folder = FreshFolder("calibration");
  const io::Scene scene = io::ReadScene(dg::testing::TinyPhantomDir() + "/scene.yaml");
  io::StereoCalibration calibration = io::ReadStereoCalibration(scene.calibration);
  const double baseline_m = calibration.T_m.norm();
  REQUIRE(baseline_m > 1e-3);
  REQUIRE(baseline_m < 0.05);

  calibration.T_m *= 1000;
  const std::string in_mm = (folder / "in_mm.yaml").string();
  io::WriteStereoCalibration(in_mm, calibration);
  REQUIRE_THROWS_WITH(io::ReadStereoCalibration(in_mm), Contains("T is probably in millimetres") &&
                                                            Contains(in_mm + ": key T") &&
                                                            Contains("divide it by 1000"));
  calibration.T_m.setZero();
  const std::string zero = (folder / "zero.yaml").string();
  io::WriteStereoCalibration(zero, calibration);
  REQUIRE_THROWS_WITH(io::ReadStereoCalibration(zero), Contains("T: is zero or not finite"));
  fs::remove_all(folder);
}

TEST_CASE("bad values: an image sequence's number field wider than a file name's", "[faults][unit]") {
  const fs::path folder = FreshFolder("sequence");
  const std::string pattern = (folder / "left_%0999999d.png").string();
  REQUIRE_THROWS_WITH(stages::ListImageSequence(pattern),
                      Contains("the number field %0999999d is wider than 18 digits") && Contains(pattern));
  fs::remove_all(folder);
}

TEST_CASE("bad values: snapshots of frames the run does not read are refused before it starts",
          "[faults][integration]") {
  tools::RunOptions options;
  options.scene = dg::testing::TinyPhantomDir() + "/scene.yaml";
  options.out_dir = FreshFolder("snapshots").string();
  options.video = false;
  options.progress = false;
  options.graph.end_frame = 10;
  options.snapshots = {5, 10};
  REQUIRE_THROWS_WITH(tools::RunScene(options), Contains("--snapshots names frame 10, outside the frames this run "
                                                         "reads (0 to 9)"));
  options.snapshots = {-1};
  REQUIRE_THROWS_WITH(tools::RunScene(options), Contains("names frame -1"));
  REQUIRE(fs::is_empty(options.out_dir));  // refused before anything was written
  fs::remove_all(options.out_dir);
}

// The tiny phantom's mesh written in millimetres, its scene left saying
// nothing of the unit (metres): the run stops at scene load, naming the unit,
// instead of simulating a 1000 times larger organ to an exit code 0.
TEST_CASE("bad values: a mesh in millimetres read as metres is refused at scene load, naming the unit",
          "[faults][integration]") {
  const std::string dir = dg::testing::TinyPhantomDir();
  const io::Scene scene = io::ReadScene(dir + "/scene.yaml");
  sim::TetMesh mesh = io::ReadGmsh(scene.mesh.file, scene.mesh.metres_per_unit);
  mesh.X_m *= 1000;
  io::WriteMsh(mesh, dir + "/mesh_in_mm.msh", 41);
  std::string text = scene.text;
  const size_t at = text.find("mesh.msh");
  REQUIRE(at != std::string::npos);
  text.replace(at, 8, "mesh_in_mm.msh");
  const tools::RunOptions options = VariantRun("mesh_in_mm", text);
  REQUIRE_THROWS_WITH(tools::RunScene(options), Contains("coordinates are probably in millimetres") &&
                                                    Contains("mesh_in_mm.msh") && Contains("units: mm"));
  REQUIRE(fs::is_empty(options.out_dir));
  fs::remove_all(options.out_dir);
}

// A time step above the mesh's stable limit is refused when the scene loads,
// before a frame is read, naming the key, the limit and where the mesh sets
// it, instead of inverting an element at the first simulated frame.
TEST_CASE("bad values: a simulation time step above the mesh's stable limit is refused at scene load, or substepped",
          "[faults][integration]") {
  const std::string dir = dg::testing::TinyPhantomDir();
  const io::Scene scene = io::ReadScene(dir + "/scene.yaml");
  std::string text = scene.text;
  const size_t at = text.find("dt_s: 2.0e-4");
  REQUIRE(at != std::string::npos);
  text.replace(at, 12, "dt_s: 2.0e-3");
  const tools::RunOptions options = VariantRun("large_dt", text);
  REQUIRE_THROWS_WITH(tools::RunScene(options), Contains("simulation.dt_s: time step 2 ms exceeds") &&
                                                    Contains("critical time step") && Contains("highest mode") &&
                                                    Contains("set simulation.dt_s at or below") &&
                                                    Contains("time_step_policy: substep"));
  REQUIRE(fs::is_empty(options.out_dir));

  // Asked to substep, the run splits each step into the fewest stable ones:
  // every frame's step is below the stable fraction (0.9 of dt_cr at the
  // phantom's nu = 0.45) and above half of it.
  text.replace(text.find("dt_s: 2.0e-3"), 12, "dt_s: 2.0e-3\n  time_step_policy: substep");
  const tools::RunOptions substepping = VariantRun("large_dt_substep", text);
  const tools::RunOutcome outcome = tools::RunScene(substepping);
  REQUIRE(outcome.simulated_frames > 0);
  const hid_t file = H5Fopen((substepping.out_dir + "/run.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(testing::h5_plain::IntAttribute(file, "/", "complete") == 1);
  for (double ratio : testing::h5_plain::Doubles(file, "/sim/dt_over_dt_critical")) {
    CHECK(ratio <= sim::DefaultStabilitySafety(scene.material.poissons_ratio));
    CHECK(ratio > 0.5 * sim::DefaultStabilitySafety(scene.material.poissons_ratio));
  }
  H5Fclose(file);
  fs::remove_all(options.out_dir);
  fs::remove_all(substepping.out_dir);
}

// The same video for both eyes, or the eyes exchanged, stop the run at frame
// 0 naming the cause (at capture: the frames are equal pixel for pixel; at
// tracking: few points match along their rows and the right image is shifted
// the wrong way), instead of tracking a handful of points and blaming the
// fiducials later. The log is kept and marked incomplete with that error.
TEST_CASE("bad values: both eyes the same video, or the eyes exchanged, stop the run naming the cause",
          "[faults][integration]") {
  const std::string dir = dg::testing::TinyPhantomDir();
  const io::Scene scene = io::ReadScene(dir + "/scene.yaml");
  const size_t left = scene.text.find("left: video/left.avi"), right = scene.text.find("right: video/right.avi");
  REQUIRE(left != std::string::npos);
  REQUIRE(right != std::string::npos);
  struct Case {
    std::string name, left, right, expected;
  };
  for (const Case& c : {Case{"same_eyes", "left.avi", "left.avi", "is the same in both eyes, pixel for pixel"},
                        Case{"swapped_eyes", "right.avi", "left.avi", "the left and right eyes look swapped"}}) {
    std::string text = scene.text;
    text.replace(right, 22, "right: video/" + c.right);
    text.replace(left, 20, "left: video/" + c.left);
    const tools::RunOptions options = VariantRun(c.name, text);
    INFO(c.name);
    REQUIRE_THROWS_WITH(tools::RunScene(options), Contains(c.expected) && Contains("frame 0") &&
                                                      Contains("video.left and video.right"));
    const hid_t file = H5Fopen((options.out_dir + "/run.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    REQUIRE(file >= 0);
    CHECK(testing::h5_plain::IntAttribute(file, "/", "complete") == 0);
    CHECK_THAT(testing::h5_plain::StringAttribute(file, "/", "error"), Contains(c.expected));
    H5Fclose(file);
    fs::remove_all(options.out_dir);
  }
}

// A CT whose spacing was written in metres (MetaImage states millimetres), or
// whose origin puts the mesh outside it, is refused when the scene loads,
// naming the CT and the likely cause: the overlays would otherwise sample
// air, and the fiducials the registration finds in it would not be the mesh's.
TEST_CASE("bad values: a CT grid in another unit or another frame than the mesh is refused at scene load",
          "[faults][integration]") {
  const std::string dir = dg::testing::TinyPhantomDir();
  const io::Scene scene = io::ReadScene(dir + "/scene.yaml");
  struct Case {
    std::string name, key, value, expected;
  };
  for (const Case& c : {Case{"ct_in_metres", "ElementSpacing", "0.001 0.001 0.001", "in another unit"},
                        Case{"ct_elsewhere", "Offset", "300 300 300", "outside the CT's grid"}}) {
    INFO(c.name);
    const fs::path copy = fs::path(dir) / c.name;
    fs::remove_all(copy);
    fs::copy(fs::path(dir) / "ct", copy, fs::copy_options::recursive);
    for (const auto& entry : fs::directory_iterator(copy)) {
      if (entry.path().extension() != ".mhd") continue;
      std::ifstream in(entry.path());
      std::string text, line;
      while (std::getline(in, line)) text += (line.rfind(c.key + " =", 0) == 0 ? c.key + " = " + c.value : line) + "\n";
      in.close();
      std::ofstream(entry.path()) << text;
    }
    std::string text = scene.text;
    const size_t at = text.find("ct: ct/");
    REQUIRE(at != std::string::npos);
    text.replace(at, 7, "ct: " + c.name + "/");
    const tools::RunOptions options = VariantRun(c.name, text);
    REQUIRE_THROWS_WITH(tools::RunScene(options), Contains(c.expected) && Contains(c.name + "/phase_00.mhd"));
    REQUIRE(fs::is_empty(options.out_dir));
    fs::remove_all(options.out_dir);
  }
}

}  // namespace
}  // namespace dg
