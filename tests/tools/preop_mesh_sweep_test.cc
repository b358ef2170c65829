// Every preop mesh is good enough to simulate: over 20 phantom seeds and
// three heart rates, phase 0 of the phantom's CT segmented, its surface
// extracted and meshed as `dynaguide preop` does (MeshForScene), then checked
// against what `dynaguide run` requires (docs/preop.md, "The mesh's
// stability limit"): worst radius ratio at least 0.15 and the assembled
// critical time step at least the scene's 0.2 ms over run's safety fraction.
#include <catch2/catch.hpp>

#include "io/scene.h"
#include "stages/preop/segment/segmentation.h"
#include "stages/preop/segment/surface_extraction.h"
#include "stages/preop/segment/tetrahedralisation.h"
#include "tools/phantom/ct_synthesis.h"
#include "tools/phantom/heart_geometry.h"
#include "tools/phantom/heart_motion.h"
#include "tools/phantom/phantom_spec.h"
#include "tools/phantom/surface_assets.h"
#include "tools/preop/preop_job.h"

namespace dg::tools::preop {
namespace {

io::CtImage PhantomPhase0(std::uint64_t seed, double heart_rate_bpm) {
  phantom::PhantomSpec spec = phantom::PresetSpec("default");
  spec.seed = seed;
  spec.heart_rate_bpm = heart_rate_bpm;
  const phantom::HeartGeometry geometry(spec);
  const phantom::HeartMotion motion(spec, spec.period_s());
  const phantom::SurfaceAssets assets = phantom::MakeSurfaceAssets(spec, geometry, /*camera_azimuth_u=*/0.75);
  const io::VolumeI16 ct =
      phantom::SynthesizeCtPhase(phantom::MakeCtGrid(spec), geometry, motion, phantom::HeartMotion::NominalState(0.0),
                                 assets.fiducials_S, spec.ct_noise_hu, spec.seed, 0);
  return io::ToCtImage(ct, "phantom seed " + std::to_string(seed) + ", " + std::to_string(heart_rate_bpm) + " bpm");
}

TEST_CASE("preop meshes: 20 phantom seeds x 3 heart rates, every mesh within run's stability limit", "[slow]") {
  const io::Scene::Simulation simulation;  // the scene's defaults: dt 0.2 ms
  const sim::Material material;
  double worst_ratio = 1, worst_margin = HUGE_VAL;
  for (std::uint64_t seed = 3131; seed < 3151; ++seed) {  // 3141 gave slivers of radius ratio 0.024 before the guarantee
    for (double bpm : {60.0, 84.0, 120.0}) {
      const io::CtImage ct = PhantomPhase0(seed, bpm);
      INFO(ct.source);
      const stages::preop::Segmentation segmentation = stages::preop::Segment(ct, {});
      const io::SurfaceMesh surface = stages::preop::ExtractSurface(segmentation.organ, {});
      stages::preop::TetrahedralisationReport report;
      MeshStability stability;
      const sim::TetMesh mesh =
          MeshForScene(surface, segmentation.mount, {}, material, simulation.dt_s, &report, &stability);
      INFO("radius ratio " << report.min_radius_ratio << ", " << stability.limit);
      CHECK(report.min_radius_ratio >= 0.15);
      CHECK(stability.excess.empty());
      worst_ratio = std::min(worst_ratio, report.min_radius_ratio);
      worst_margin = std::min(worst_margin, stability.safety * stability.dt_critical_s / simulation.dt_s);
    }
  }
  WARN("worst radius ratio " << worst_ratio << "; worst stable step over the scene's " << worst_margin);
}

}  // namespace
}  // namespace dg::tools::preop
