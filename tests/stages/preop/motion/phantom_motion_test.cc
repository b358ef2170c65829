#include <algorithm>
#include <vector>

#include <catch2/catch.hpp>

#include "io/gmsh_mesher.h"
#include "stages/preop/motion/motion_registration.h"
#include "tools/phantom/ct_synthesis.h"
#include "tools/phantom/heart_geometry.h"
#include "tools/phantom/heart_motion.h"
#include "tools/phantom/phantom_spec.h"
#include "tools/phantom/surface_assets.h"

namespace dg::stages::preop {
namespace {

using namespace dg::tools::phantom;

struct Errors {
  double mean_mm = 0, max_mm = 0;
};

// Recovered against true displacements of the same points, in millimetres.
Errors Compare(const Eigen::Matrix3Xd& recovered_m, const Eigen::Matrix3Xd& truth_m) {
  Errors errors;
  for (Eigen::Index i = 0; i < truth_m.cols(); ++i) {
    const double error_mm = (recovered_m.col(i) - truth_m.col(i)).norm() * 1000;
    errors.mean_mm += error_mm / truth_m.cols();
    errors.max_mm = std::max(errors.max_mm, error_mm);
  }
  return errors;
}

// The default phantom's CT at phase 0, a mid-contraction phase and the peak
// (phase 10 of 20, 3.84 mm), made as `dynaguide phantom` makes them; the truth
// is the phantom's analytic motion at the nodes of its mesh and at its
// fiducials (what scan.h5 records).
TEST_CASE("motion registration: the phantom's motion at its mesh nodes and fiducials", "[integration]") {
  const PhantomSpec spec = PresetSpec("default");
  const HeartGeometry geometry(spec);
  const HeartMotion motion(spec, 1.0);
  const SurfaceAssets assets = MakeSurfaceAssets(spec, geometry, /*camera_azimuth_u=*/0.75);
  const sim::TetMesh mesh = io::MeshTruncatedEllipsoid({spec.semi_axes_m, spec.centre_height_m, spec.tets});
  const io::VolumeI16 grid = MakeCtGrid(spec);
  const std::vector<int> phase_ids = {0, 5, 10};
  std::vector<io::CtImage> phases;
  for (int k : phase_ids) {
    const MotionState state = HeartMotion::NominalState(double(k) / spec.phases);
    phases.push_back(io::ToCtImage(
        SynthesizeCtPhase(grid, geometry, motion, state, assets.fiducials_S, spec.ct_noise_hu, spec.seed, k),
        "phase " + std::to_string(k)));
  }
  const std::vector<PhaseDeformation> deformations = RegisterPhases(phases, MotionRegistrationOptions{});

  for (size_t p = 1; p < phase_ids.size(); ++p) {
    const MotionState state = HeartMotion::NominalState(double(phase_ids[p]) / spec.phases);
    Eigen::Matrix3Xd nodes_truth_m(3, mesh.num_nodes()), fiducials_truth_m(3, assets.fiducials_S.cols());
    for (int a = 0; a < mesh.num_nodes(); ++a) nodes_truth_m.col(a) = motion.Deform(mesh.X_m.col(a), state) - mesh.X_m.col(a);
    for (Eigen::Index f = 0; f < assets.fiducials_S.cols(); ++f) {
      fiducials_truth_m.col(f) = motion.Deform(assets.fiducials_S.col(f), state) - assets.fiducials_S.col(f);
    }
    const Errors nodes = Compare(deformations[p].Displacements(mesh.X_m), nodes_truth_m);
    const Errors fiducials = Compare(deformations[p].Displacements(assets.fiducials_S), fiducials_truth_m);
    const PhaseRegistrationReport& report = deformations[p].report();
    INFO("phase " << phase_ids[p] << ": nodes mean " << nodes.mean_mm << " max " << nodes.max_mm
                  << " mm; fiducials mean " << fiducials.mean_mm << " max " << fiducials.max_mm << " mm; J ["
                  << report.min_jacobian << ", " << report.max_jacobian << "]");
    // Measured (default options, samples 3 mm apart): nodes phase 5 0.17 /
    // 0.65 mm (mean / max), phase 10 0.37 / 1.42 mm; fiducials 0.06 and
    // 0.10 mm mean (every voxel: 0.02 and 0.05, with nodes at 0.31 / 0.97 and
    // 0.41 / 1.72 mm). Bounds about twice.
    CHECK(nodes.mean_mm < 0.75);
    CHECK(nodes.max_mm < 2.9);
    CHECK(fiducials.mean_mm < 0.2);
    CHECK(report.min_jacobian > 0.3);
    CHECK(report.metric_after < report.metric_before);
  }
}

}  // namespace
}  // namespace dg::stages::preop
