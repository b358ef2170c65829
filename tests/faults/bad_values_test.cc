// Values a user gets wrong, which would otherwise pass unnoticed or end in
// an "unexpected error": each is refused with what, where and a fix.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "io/calibration.h"
#include "io/gmsh_mesher.h"
#include "io/gmsh_reader.h"
#include "io/registration_file.h"
#include "io/scene.h"
#include "io/surface_mesh.h"
#include "io/surface_mesh_reader.h"
#include "pipeline/overlay_stages.h"
#include "pipeline/run_scene.h"
#include "sim/error.h"
#include "sim/stability.h"
#include "stages/image_sequence.h"
#include "tests/support/h5_plain.h"
#include "tests/support/temporary_folder.h"
#include "tests/support/tiny_phantom.h"

namespace dg {
namespace {

namespace fs = std::filesystem;
using Catch::Matchers::Contains;

// An empty folder `name` in this process's own temporary folder, which goes when the process exits.
fs::path FreshFolder(const std::string& name) {
  static const testing::TemporaryFolder outputs("dg_faults");
  const fs::path folder = outputs.File(name);
  fs::remove_all(folder);
  fs::create_directories(folder);
  return folder;
}

// A run of the tiny phantom's scene as `text` gives it (written beside the
// scene as scene_NAME.yaml) into a fresh folder, without video or progress.
pipeline::RunOptions VariantRun(const std::string& name, const std::string& text) {
  const std::string path = dg::testing::TinyPhantomDir() + "/scene_" + name + ".yaml";
  std::ofstream(path) << text;
  pipeline::RunOptions options;
  options.scene = path;
  options.out_dir = FreshFolder(name).string();
  options.video = false;
  options.progress = false;
  return options;
}

// The depths "lie at A m to B m" a working-distance error names, or {-1, -1}.
std::pair<double, double> NamedDepths(const std::string& message) {
  std::smatch match;
  if (!std::regex_search(message, match, std::regex("lie at ([-0-9.e+]+) m to ([-0-9.e+]+) m"))) return {-1, -1};
  return {std::stod(match[1]), std::stod(match[2])};
}

// The message of the dg::Error a run throws ("" when it throws none).
std::string RunError(const pipeline::RunOptions& options) {
  try {
    pipeline::RunScene(options);
  } catch (const Error& e) {
    return e.what();
  }
  return {};
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
}

TEST_CASE("bad values: an image sequence's number field wider than a file name's", "[faults][unit]") {
  const fs::path folder = FreshFolder("sequence");
  const std::string pattern = (folder / "left_%0999999d.png").string();
  REQUIRE_THROWS_WITH(stages::ListImageSequence(pattern),
                      Contains("the number field %0999999d is wider than 18 digits") && Contains(pattern));
}

TEST_CASE("bad values: snapshots of frames the run does not read are refused before it starts",
          "[faults][integration]") {
  pipeline::RunOptions options;
  options.scene = dg::testing::TinyPhantomDir() + "/scene.yaml";
  options.out_dir = FreshFolder("snapshots").string();
  options.video = false;
  options.progress = false;
  options.graph.end_frame = 10;
  options.snapshots = {5, 10};
  REQUIRE_THROWS_WITH(pipeline::RunScene(options), Contains("--snapshots names frame 10, outside the frames this run "
                                                         "reads (0 to 9)"));
  options.snapshots = {-1};
  REQUIRE_THROWS_WITH(pipeline::RunScene(options), Contains("names frame -1"));
  REQUIRE(fs::is_empty(options.out_dir));  // refused before anything was written
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
  const pipeline::RunOptions options = VariantRun("mesh_in_mm", text);
  REQUIRE_THROWS_WITH(pipeline::RunScene(options), Contains("coordinates are probably in millimetres") &&
                                                    Contains("mesh_in_mm.msh") && Contains("units: mm"));
  REQUIRE(fs::is_empty(options.out_dir));
}

// The overlay meshes written in millimetres, as 3D Slicer writes them (the
// skin as OBJ with its texture coordinates, the chambers as binary PLY):
// read as metres they are refused at scene load, naming `units: mm`; with
// `overlays: {units: mm}` they load to the original metres and the run draws them.
TEST_CASE("bad values: overlay meshes in millimetres are refused without units and drawn with units: mm",
          "[faults][integration]") {
  const std::string dir = dg::testing::TinyPhantomDir();
  const io::Scene scene = io::ReadScene(dir + "/scene.yaml");
  const io::SurfaceFileOptions millimetres{1e-3, ""};
  io::WriteObj(dir + "/assets/skin_mm.obj", io::ReadSurfaceMesh(scene.overlays->surface_mesh), millimetres);
  std::string text = scene.text;
  for (const char* name : {"skin.obj", "chamber_0.obj", "chamber_1.obj"}) {
    const std::string mm_name = std::string(name) == "skin.obj" ? "skin_mm.obj"
                                                                 : std::string(name).substr(0, 9) + "_mm.ply";
    if (mm_name.ends_with(".ply")) {
      io::WritePly(dir + "/assets/" + mm_name, io::ReadSurfaceMesh(dir + "/assets/" + name), millimetres);
    }
    const size_t at = text.find(std::string("assets/") + name);
    REQUIRE(at != std::string::npos);
    text.replace(at + 7, std::string(name).size(), mm_name);
  }
  const pipeline::RunOptions as_metres = VariantRun("overlays_in_mm", text);
  const std::string error = RunError(as_metres);
  CHECK_THAT(error, Contains("_mm.") && Contains("units: mm"));

  const size_t overlays = text.find("overlays:\n");
  REQUIRE(overlays != std::string::npos);
  text.insert(overlays + 10, "  units: mm\n");
  const pipeline::RunOptions with_units = VariantRun("overlays_with_units", text);
  const io::Scene loaded = io::ReadScene(with_units.scene);
  const std::vector<stages::overlay::OverlaySurface> chambers = pipeline::InternalMeshSurfaces(*loaded.overlays);
  REQUIRE(chambers.size() == 2);
  const io::SurfaceMesh original = io::ReadSurfaceMesh(dir + "/assets/chamber_0.obj");
  CHECK((chambers[0].mesh.vertices_m - original.vertices_m).cwiseAbs().maxCoeff() < 1e-15);
  CHECK((pipeline::TexturedSurface(*loaded.overlays).mesh.uvs.size() > 0));
  pipeline::RunScene(with_units);
  const hid_t file = H5Fopen((with_units.out_dir + "/run.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(testing::h5_plain::IntAttribute(file, "/overlay_timings", "meshes_drawn") >= 1);
  H5Fclose(file);
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
  const pipeline::RunOptions options = VariantRun("large_dt", text);
  REQUIRE_THROWS_WITH(pipeline::RunScene(options), Contains("simulation.dt_s: time step 2 ms exceeds") &&
                                                    Contains("critical time step") && Contains("highest mode") &&
                                                    Contains("set simulation.dt_s at or below") &&
                                                    Contains("time_step_policy: substep"));
  REQUIRE(fs::is_empty(options.out_dir));

  // Asked to substep, the run splits each step into the fewest stable ones:
  // every frame's step is below the stable fraction (0.9 of dt_cr at the
  // phantom's nu = 0.45) and above half of it.
  text.replace(text.find("dt_s: 2.0e-3"), 12, "dt_s: 2.0e-3\n  time_step_policy: substep");
  const pipeline::RunOptions substepping = VariantRun("large_dt_substep", text);
  const pipeline::RunOutcome outcome = pipeline::RunScene(substepping);
  REQUIRE(outcome.simulated_frames > 0);
  const hid_t file = H5Fopen((substepping.out_dir + "/run.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(testing::h5_plain::IntAttribute(file, "/", "complete") == 1);
  for (double ratio : testing::h5_plain::Doubles(file, "/sim/dt_over_dt_critical")) {
    CHECK(ratio <= sim::DefaultStabilitySafety(scene.material.poissons_ratio));
    CHECK(ratio > 0.5 * sim::DefaultStabilitySafety(scene.material.poissons_ratio));
  }
  H5Fclose(file);
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
    const pipeline::RunOptions options = VariantRun(c.name, text);
    INFO(c.name);
    REQUIRE_THROWS_WITH(pipeline::RunScene(options), Contains(c.expected) && Contains("frame 0") &&
                                                      Contains("video.left and video.right"));
    const hid_t file = H5Fopen((options.out_dir + "/run.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    REQUIRE(file >= 0);
    CHECK(testing::h5_plain::IntAttribute(file, "/", "complete") == 0);
    CHECK_THAT(testing::h5_plain::StringAttribute(file, "/", "error"), Contains(c.expected));
    H5Fclose(file);
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
    const pipeline::RunOptions options = VariantRun(c.name, text);
    REQUIRE_THROWS_WITH(pipeline::RunScene(options), Contains(c.expected) && Contains(c.name + "/phase_00.mhd"));
    REQUIRE(fs::is_empty(options.out_dir));
  }
}

// A depth range given in millimetres (--near 30 --far 300) matches no
// fiducial, so the run would register nothing and blame their tracking. The
// first stereo pair measures the fiducials' depth along the whole row, and
// the run stops at frame 0 naming the depths, which agree with the truth's,
// the unit, and a range in metres that holds them.
TEST_CASE("bad values: a depth range in millimetres is refused at the first frame, naming the tissue's depth",
          "[faults][integration]") {
  const std::string dir = dg::testing::TinyPhantomDir();
  pipeline::RunOptions options = VariantRun("range_in_mm", io::ReadScene(dir + "/scene.yaml").text);
  options.front_end.near_m = 30;
  options.front_end.far_m = 300;
  const std::string message = RunError(options);
  INFO(message);
  CHECK_THAT(message, Contains("the fiducials, matched in the first stereo pair,") && Contains("frame 0") &&
                          Contains("--near and --far are probably in millimetres") && Contains("in metres, e.g. --near"));
  // The truth's depths of the fiducials the left camera sees in frame 0.
  const hid_t truth = H5Fopen((dir + "/truth.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(truth >= 0);
  const std::vector<double> xyz = testing::h5_plain::Doubles(truth, "/fiducials/xyz_C_m");
  const std::vector<double> visible = testing::h5_plain::Doubles(truth, "/fiducials/visible_left");
  H5Fclose(truth);
  const size_t fiducials = xyz.size() / 3 / 30;
  REQUIRE(visible.size() == 30 * fiducials);
  double true_nearest = 1e9, true_farthest = 0;
  for (size_t i = 0; i < fiducials; ++i) {
    if (visible[i] == 0) continue;
    true_nearest = std::min(true_nearest, xyz[3 * i + 2]);
    true_farthest = std::max(true_farthest, xyz[3 * i + 2]);
  }
  REQUIRE(true_farthest > 0);
  // Triangulated at 8-10 px of disparity, where a tenth of a pixel is under a
  // millimetre. The farthest marker's match at 160x120 is 1.2 px short (the
  // tracker's own match in range is the same), 11 mm of depth there.
  const auto [nearest, farthest] = NamedDepths(message);
  CHECK(nearest == Approx(true_nearest).margin(1e-3));
  CHECK(farthest == Approx(true_farthest).margin(0.012));
  CHECK(nearest <= farthest);
  std::smatch fix;
  REQUIRE(std::regex_search(message, fix, std::regex("--near ([0-9.e+-]+) --far ([0-9.e+-]+)")));
  CHECK(std::stod(fix[1]) < true_nearest);
  CHECK(std::stod(fix[2]) > true_farthest);
}

// The scene's own registration, its translation written in millimetres,
// puts the tissue a thousand times too far: refused when the scene loads,
// before a frame is read, naming the registration file and the depths of
// the scan's fiducials through it (here recomputed from the truth's pose).
TEST_CASE("bad values: a given registration in millimetres is refused at scene load, naming its depths",
          "[faults][integration]") {
  const std::string dir = dg::testing::TinyPhantomDir();
  const io::Scene scene = io::ReadScene(dir + "/scene.yaml");
  const hid_t truth = H5Fopen((dir + "/truth.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(truth >= 0);
  const std::vector<double> T = testing::h5_plain::Doubles(truth, "/T_C_S");  // row-major 4x4
  const std::vector<double> X_S = testing::h5_plain::Doubles(truth, "/fiducials/X_S_m");
  io::Registration registration;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) registration.T_C_S(r, c) = T[4 * r + c];
  }
  registration.phase_shift_s = testing::h5_plain::Doubles(truth, "/phase_shift_s").at(0);
  registration.period_s = testing::h5_plain::Doubles(truth, "/period_s").at(0);
  H5Fclose(truth);
  registration.T_C_S.topRightCorner<3, 1>() *= 1000;
  io::WriteRegistrationYaml(dir + "/pose_in_mm.yaml", registration);
  std::string text = scene.text;
  const size_t at = text.find("registration:\n  cycles: 1");
  REQUIRE(at != std::string::npos);
  text.replace(at, 25, "registration:\n  file: pose_in_mm.yaml");
  const pipeline::RunOptions options = VariantRun("pose_in_mm", text);
  const std::string message = RunError(options);
  INFO(message);
  CHECK_THAT(message, Contains("the scan's fiducials, placed by registration.file,") &&
                          Contains("these depths are probably in millimetres") && Contains("pose_in_mm.yaml") &&
                          Contains("translation in metres"));
  double nearest_mm = 1e9, farthest_mm = 0;  // depths through the pose in millimetres, in "metres"
  for (size_t i = 0; i + 2 < X_S.size(); i += 3) {
    const double z = T[8] * X_S[i] + T[9] * X_S[i + 1] + T[10] * X_S[i + 2] + 1000 * T[11];
    nearest_mm = std::min(nearest_mm, z);
    farthest_mm = std::max(farthest_mm, z);
  }
  // The scan's fiducials are the beads found in its CT, within a voxel (1 mm)
  // of the truth's; the message gives four digits (0.01 here).
  const auto [nearest, farthest] = NamedDepths(message);
  CHECK(nearest == Approx(nearest_mm).margin(0.011));
  CHECK(farthest == Approx(farthest_mm).margin(0.011));
  CHECK(fs::is_empty(options.out_dir));
}

// First-frame fiducial pixels as a user gives them (registration.fiducials_uv,
// here the truth's first frame): in another order they are reassigned, and the
// run registers exactly as with the right order; one pixel beside its marker
// is refused when the registration solves, naming the track, with the log
// marked incomplete.
TEST_CASE("bad values: fiducial pixels out of order are reassigned, a pixel beside its marker is refused",
          "[faults][integration]") {
  const std::string dir = dg::testing::TinyPhantomDir();
  const io::Scene scene = io::ReadScene(dir + "/scene.yaml");
  const size_t block = scene.text.find("registration:\n");
  REQUIRE(block != std::string::npos);
  const hid_t truth = H5Fopen((dir + "/truth.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(truth >= 0);
  const std::vector<double> uv = testing::h5_plain::Doubles(truth, "/fiducials/uv_left_px");  // [frames, F, 2]
  const int fiducials = static_cast<int>(uv.size() / testing::h5_plain::Rows(truth, "/fiducials/uv_left_px") / 2);
  H5Fclose(truth);
  REQUIRE(fiducials == 6);
  // A run from the truth's first-frame pixels, track i starting at the pixel of scan fiducial order[i].
  auto run_from = [&](const std::string& name, const std::vector<int>& order, double shift_first_px) {
    const std::string pixels = dir + "/" + name + "_uv.txt";
    std::ofstream file(pixels);
    for (int i = 0; i < fiducials; ++i) {
      file << uv[2 * order[i]] + (i == 0 ? shift_first_px : 0.0) << "," << uv[2 * order[i] + 1] << "\n";
    }
    file.close();
    std::string text = scene.text;
    text.insert(block + 14, "  fiducials_uv: " + pixels + "\n");
    return VariantRun(name, text);
  };
  auto read_log = [](const pipeline::RunOptions& options, const char* dataset) {
    const hid_t file = H5Fopen((options.out_dir + "/run.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    REQUIRE(file >= 0);
    std::vector<double> values = testing::h5_plain::Doubles(file, dataset);
    CHECK(testing::h5_plain::IntAttribute(file, "/", "complete") == 1);
    H5Fclose(file);
    return values;
  };

  const pipeline::RunOptions in_order = run_from("uv_in_order", {0, 1, 2, 3, 4, 5}, 0);
  pipeline::RunScene(in_order);
  const pipeline::RunOptions swapped = run_from("uv_swapped", {1, 0, 3, 2, 4, 5}, 0);
  pipeline::RunScene(swapped);
  CHECK(read_log(swapped, "/registration/assignment/scan_fiducial_of_track") == std::vector<double>{1, 0, 3, 2, 4, 5});
  CHECK(read_log(in_order, "/registration/assignment/scan_fiducial_of_track") == std::vector<double>{0, 1, 2, 3, 4, 5});
  // The reassigned tracks are the same tracks in the scan's order: the same registration, to the bit.
  CHECK(read_log(swapped, "/registration/T_C_S") == read_log(in_order, "/registration/T_C_S"));

  // Fiducial 0's pixel 8 px (5% of the frame) to the right: the track departs
  // about 6 px from the pose the other five fit, against 1 px for the right pixels.
  const pipeline::RunOptions beside = run_from("uv_beside", {0, 1, 2, 3, 4, 5}, 8);
  const std::string message = RunError(beside);
  CHECK_THAT(message, Contains("fit the scan's fiducials in no order") && Contains("track 0 departs") &&
                          Contains("registration.fiducials_uv"));
  const hid_t file = H5Fopen((beside.out_dir + "/run.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(testing::h5_plain::IntAttribute(file, "/", "complete") == 0);
  CHECK_THAT(testing::h5_plain::StringAttribute(file, "/", "error"), Contains("stage 'register'"));
  H5Fclose(file);
}

}  // namespace
}  // namespace dg
