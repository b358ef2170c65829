// `dynaguide preop` end to end on the tiny phantom's DICOM 4D CT, against the
// phantom's exact motion (truth/dvf_phase_NN.mha, its scan's fiducials).
#include <filesystem>

#include <catch2/catch.hpp>

#include "io/gmsh_reader.h"
#include "io/h5_file.h"
#include "io/scene.h"
#include "sim/error.h"
#include "tests/support/temporary_folder.h"
#include "tests/support/text_file.h"
#include "tests/support/tiny_phantom.h"
#include "tests/tools/tiny_preop_options.h"
#include "tools/preop/preop_bench.h"
#include "tools/preop/preop_job.h"

namespace dg::tools::preop {
namespace {

namespace fs = std::filesystem;
using Catch::Matchers::Contains;

using testing::ReadText;

TEST_CASE("preop: the tiny phantom's DICOM CT to a scene whose motion matches the phantom's", "[integration]") {
  const dg::testing::TemporaryFolder folder("dg_preop_test");
  const std::string& out = folder.path();
  const PreopSummary summary = RunPreop(TinyOptions(out));

  REQUIRE(summary.phases == 10);
  REQUIRE(ReadText(out + "/preop.json").find("\"complete\": true") != std::string::npos);
  const io::Scene scene = io::ReadScene(out + "/scene.yaml");  // what run, register and eval read
  REQUIRE(scene.preoperative->phases == 10);
  REQUIRE(scene.preoperative->ct_volumes.size() == 10);
  const sim::TetMesh mesh = io::ReadGmsh(scene.mesh.file);
  REQUIRE(mesh.num_nodes() == summary.mesh.nodes);
  REQUIRE(!mesh.node_sets.at("base").empty());
  REQUIRE(summary.mesh.min_radius_ratio > 0.1);

  const PreopMotionErrors errors = EvaluatePreopMotion(out, testing::TinyPhantomDir());
  INFO("nodes mean " << errors.node_error_mean_mm << " max " << errors.node_error_max_mm << " mm; fiducials deformed "
                     << errors.fiducial_deformed_mean_mm << " found " << errors.fiducial_found_mean_mm << " mm");
  // Achieved on the tiny phantom's 1.5 mm grid: nodes 0.36 / 2.34 mm, fiducials 0.21 / 0.19 mm.
  CHECK(errors.node_error_mean_mm < 0.75);
  CHECK(errors.node_error_max_mm < 4.5);
  CHECK(errors.fiducial_deformed_mean_mm < 0.4);
  CHECK(errors.fiducial_found_mean_mm < 0.4);
}

TEST_CASE("preop: a failed step leaves its report marked incomplete with the error", "[integration]") {
  const dg::testing::TemporaryFolder folder("dg_preop_fail_test");
  const std::string& out = folder.path();
  PreopOptions options = TinyOptions(out);
  options.segmentation.organ_hu = {2500, 2600};  // between tissue and beads: nothing
  REQUIRE_THROWS_AS(RunPreop(options), Error);
  const std::string report = ReadText(out + "/preop.json");
  REQUIRE(report.find("\"complete\": false") != std::string::npos);
  REQUIRE(report.find("\"error\"") != std::string::npos);
  REQUIRE(!fs::exists(out + "/scan.h5"));
  fs::remove_all(out);

  options.like_scene.clear();
  REQUIRE_THROWS_WITH(RunPreop(options), Contains("--period-s"));
}

}  // namespace
}  // namespace dg::tools::preop
