// What `dynaguide preop` takes besides the CT: fiducials from a file, bead
// detection's options, a CT without beads, and the registrations kept between
// runs (--resume). On the tiny phantom's 4D CT, whose scan.h5 holds the
// fiducials' true positions.
#include <filesystem>
#include <fstream>

#include <catch2/catch.hpp>

#include "io/h5_file.h"
#include "io/metaimage.h"
#include "io/scene.h"
#include "sim/error.h"
#include "stages/register/bead_detection.h"
#include "stages/register/fiducial_motion.h"
#include "tests/support/temporary_folder.h"
#include "tests/support/text_file.h"
#include "tests/support/tiny_phantom.h"
#include "tests/tools/tiny_preop_options.h"
#include "tools/preop/fiducial_file.h"
#include "tools/preop/preop_job.h"

namespace dg::tools::preop {
namespace {

namespace fs = std::filesystem;
using Catch::Matchers::Contains;

void WriteText(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

// The formats as 3D Slicer 5 writes them: a markups JSON file (schema
// markups-schema-v1.0.3) and a fiducial list (.fcsv, format 4.11).
TEST_CASE("fiducial files: Slicer markups (LPS and RAS), fiducial lists and CSV give the same LPS metres", "[unit]") {
  const dg::testing::TemporaryFolder folder("dg_fiducial_file_test");
  const std::string dir = folder.path();
  WriteText(dir + "/lps.mrk.json", R"({"@schema": "https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/Markups/Resources/Schema/markups-schema-v1.0.3.json#",
 "markups": [{"type": "Fiducial", "coordinateSystem": "LPS", "coordinateUnits": "mm",
   "controlPoints": [{"id": "1", "label": "F-1", "position": [10.5, -20.0, 30.25], "positionStatus": "defined"},
                     {"id": "2", "label": "F-2", "position": [-1.0, 2.0, -3.0], "positionStatus": "defined"}]}]})");
  WriteText(dir + "/ras.mrk.json", R"({"markups": [{"type": "Fiducial", "coordinateSystem": "RAS",
   "controlPoints": [{"position": [-10.5, 20.0, 30.25]}, {"position": [1.0, -2.0, -3.0]}]}]})");
  WriteText(dir + "/ras.fcsv",
            "# Markups fiducial file version = 4.11\n# CoordinateSystem = RAS\n"
            "# columns = id,x,y,z,ow,ox,oy,oz,vis,sel,lock,label,desc,associatedNodeID\n"
            "vtkMRMLMarkupsFiducialNode_0,-10.5,20,30.25,0,0,0,1,1,1,0,F-1,,\n"
            "vtkMRMLMarkupsFiducialNode_1,1,-2,-3,0,0,0,1,1,1,0,F-2,,\n");
  WriteText(dir + "/lps_old.fcsv", "# CoordinateSystem = 1\nF-1,10.5,-20,30.25\nF-2,-1,2,-3\n");
  WriteText(dir + "/points.csv", "x,y,z\n10.5,-20,30.25\n-1,2,-3\n");
  Eigen::Matrix3Xd expected(3, 2);
  expected << 10.5e-3, -1e-3, -20e-3, 2e-3, 30.25e-3, -3e-3;
  for (const char* name : {"lps.mrk.json", "ras.mrk.json", "ras.fcsv", "lps_old.fcsv", "points.csv"}) {
    INFO(name);
    CHECK(ReadFiducialFile(dir + "/" + name).isApprox(expected, 1e-12));
  }
  WriteText(dir + "/bad.csv", "1,2,3\n4,five,6\n");
  CHECK_THROWS_WITH(ReadFiducialFile(dir + "/bad.csv"), Contains("line 2"));
  WriteText(dir + "/units.mrk.json", R"({"markups": [{"coordinateUnits": "um", "controlPoints": []}]})");
  CHECK_THROWS_WITH(ReadFiducialFile(dir + "/units.mrk.json"), Contains("coordinateUnits"));
  CHECK_THROWS_WITH(ReadFiducialFile(dir + "/lps.txt"), Contains("no such file"));
}

// Beads of 1, 2 and 8 mm (a calcification's size) in a water phantom of
// 1 mm voxels at 3000 HU.
io::VolumeI16 BeadPhantom() {
  io::VolumeI16 volume;
  volume.size = {40, 40, 40};
  volume.spacing_m = Eigen::Vector3d::Constant(1e-3);
  volume.origin_m = Eigen::Vector3d::Zero();
  volume.values.assign(volume.num_voxels(), 0);
  const auto ball = [&](Eigen::Vector3d centre_mm, double radius_mm) {
    for (int k = 0; k < 40; ++k) {
      for (int j = 0; j < 40; ++j) {
        for (int i = 0; i < 40; ++i) {
          if ((Eigen::Vector3d(i, j, k) - centre_mm).norm() <= radius_mm) volume.values[volume.Index(i, j, k)] = 3000;
        }
      }
    }
  };
  ball({10, 10, 10}, 1.0);
  ball({30, 10, 10}, 1.5);
  ball({20, 28, 25}, 4.0);
  return volume;
}

TEST_CASE("bead detection: the size range leaves out a calcification and the box what lies outside it", "[unit]") {
  const io::VolumeI16 volume = BeadPhantom();
  stages::BeadDetectionOptions options;
  // Spheres of radius 1, 1.5 and 4 mm on 1 mm voxels hold 7, 19 and 257 voxels: 2.4, 3.3 and 7.9 mm across.
  CHECK(stages::DetectBeads(volume, options).size() == 2);
  options.max_diameter_mm = 10;
  CHECK(stages::DetectBeads(volume, options).size() == 3);
  options.roi_min_m = Eigen::Vector3d(20e-3, 0, 0);
  options.roi_max_m = Eigen::Vector3d(39e-3, 39e-3, 39e-3);
  const std::vector<Eigen::Vector3d> inside = stages::DetectBeads(volume, options);
  REQUIRE(inside.size() == 2);  // the 1 mm bead at x = 10 mm is outside
  CHECK((inside[0] - Eigen::Vector3d(30e-3, 10e-3, 10e-3)).norm() < 1e-9);  // symmetric: the centroid is the centre
}

TEST_CASE("bead detection: a phase whose count differs lists every phase's count and phase 0's beads", "[unit]") {
  const std::vector<std::vector<Eigen::Vector3d>> found = {{{0.01, 0.02, 0.03}, {0.04, 0.05, 0.06}},
                                                           {{0.01, 0.02, 0.03}}};
  CHECK_THROWS_WITH(stages::MatchBeadsAcrossPhases(found, {"p0.mhd", "p1.mhd"}, {}),
                    Contains("phase 1 has 1 beads but phase 0 has 2") && Contains("per phase: 2 1") &&
                        Contains("(10.0, 20.0, 30.0)") && Contains("--fiducials"));
  CHECK(stages::MatchBeadsAcrossPhases({{}, {}}, {"p0.mhd", "p1.mhd"}, {}).num_fiducials() == 0);
}

// The phantom's beads are 3000 HU: above 5000 HU there is none. The run then
// gives a scan without fiducials; a second run with them from a file takes
// every registration from the first run's cache.
TEST_CASE("preop: a CT without beads, then its fiducials from a file with --resume", "[integration]") {
  const dg::testing::TemporaryFolder folder("dg_preop_inputs_test");
  const std::string& out = folder.path();
  PreopOptions options = TinyOptions(out);
  options.beads.threshold_hu = 5000;
  const PreopSummary first = RunPreop(options);
  CHECK(first.fiducial_source == FiducialSource::kNone);
  CHECK(first.phases_from_cache == 0);
  CHECK(first.stability.dt_critical_s * first.stability.safety >= first.stability.dt_s);
  CHECK(testing::ReadText(out + "/scene.yaml").find("NO fiducials") != std::string::npos);
  CHECK_THROWS_WITH(stages::ReadFiducialMotion(out + "/scan.h5"), Contains("--fiducials FILE"));
  const std::vector<double> first_motion = io::H5Reader(out + "/scan.h5").Read<double>("/phases/node_displacement_m");

  // The phantom's true fiducials at phase 0, as a user would mark them.
  const io::Scene phantom = io::ReadScene(TinyOptions(out).like_scene);
  const stages::FiducialMotion truth = stages::ReadFiducialMotion(phantom.preoperative->motion);
  std::ofstream csv(out + "/fiducials.csv");
  csv << "x_mm,y_mm,z_mm\n";
  for (Eigen::Index f = 0; f < truth.positions_S_m[0].cols(); ++f) {
    const Eigen::Vector3d p_mm = 1e3 * truth.positions_S_m[0].col(f);
    csv << p_mm.x() << "," << p_mm.y() << "," << p_mm.z() << "\n";
  }
  csv.close();
  options.fiducials_file = out + "/fiducials.csv";
  options.resume = true;
  const PreopSummary second = RunPreop(options);
  CHECK(second.phases_from_cache == second.phases - 1);
  CHECK(second.fiducial_source == FiducialSource::kFile);
  // The same registrations, to the bit.
  CHECK(io::H5Reader(out + "/scan.h5").Read<double>("/phases/node_displacement_m") == first_motion);

  // The file's fiducials, moved by the registration, against where the
  // phantom's beads truly are in each phase. Achieved on the tiny phantom:
  // 0.059 mm mean, 0.20 mm at most.
  const stages::FiducialMotion moved = stages::ReadFiducialMotion(out + "/scan.h5");
  REQUIRE(moved.num_phases() == truth.num_phases());
  double sum_m = 0, max_m = 0;
  for (int k = 0; k < truth.num_phases(); ++k) {
    const Eigen::VectorXd error = (moved.positions_S_m[k] - truth.positions_S_m[k]).colwise().norm();
    sum_m += error.sum();
    max_m = std::max(max_m, error.maxCoeff());
  }
  const double mean_m = sum_m / (truth.num_phases() * truth.num_fiducials());
  INFO("fiducials from the file, moved: mean " << 1e3 * mean_m << " mm, max " << 1e3 * max_m << " mm");
  CHECK(mean_m < 0.12e-3);
  CHECK(max_m < 0.4e-3);
}

}  // namespace
}  // namespace dg::tools::preop
