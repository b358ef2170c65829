#include "tools/phantom/ct_synthesis.h"

#include <cmath>
#include <random>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "tools/phantom/surface_assets.h"

namespace dg::tools::phantom {
namespace {

double MaterialHu(const HeartGeometry& geometry, const HeartMotion& motion, const MotionState& state,
                  const Eigen::Vector3d& x) {
  if (HeartGeometry::InMount(x)) return kMountHu;
  const Eigen::Vector3d X = motion.Undeform(x, state);
  if (!geometry.InTissue(X)) return kAirHu;
  if (geometry.ChamberAt(X) >= 0) return kChamberHu;
  return geometry.InVessel(X) ? kFatHu : kTissueHu;
}

}  // namespace

io::VolumeI16 MakeCtGrid(const PhantomSpec& spec) {
  const double margin = 0.006 + spec.sway_m.norm();
  const double reach_xy = spec.semi_axes_m.head<2>().maxCoeff() + margin;
  io::VolumeI16 grid;
  grid.spacing_m.setConstant(spec.voxel_m);
  grid.origin_m = Eigen::Vector3d(-reach_xy, -reach_xy, -HeartGeometry::kMountThickness_m);
  const Eigen::Vector3d extent(2 * reach_xy, 2 * reach_xy, spec.height_m() + margin + HeartGeometry::kMountThickness_m);
  grid.size = (extent / spec.voxel_m).array().ceil().cast<int>() + 1;
  return grid;
}

io::VolumeI16 SynthesizeCtPhase(const io::VolumeI16& grid, const HeartGeometry& geometry, const HeartMotion& motion,
                                const MotionState& state, const Eigen::Matrix3Xd& fiducials_S, double noise_hu,
                                uint64_t seed, int phase_index) {
  io::VolumeI16 volume = grid;
  volume.values.assign(volume.num_voxels(), 0);
  const double h = volume.spacing_m.x();
  Eigen::Matrix3Xd beads(3, fiducials_S.cols());
  for (int f = 0; f < fiducials_S.cols(); ++f) beads.col(f) = motion.Deform(fiducials_S.col(f), state);
  const double bead_r = SurfaceAssets::kBeadRadius_m;

  tbb::parallel_for(tbb::blocked_range<int>(0, volume.size.z()), [&](const tbb::blocked_range<int>& slices) {
    for (int k = slices.begin(); k != slices.end(); ++k) {
      // One generator per slice, seeded by (seed, phase, slice): the noise does
      // not depend on how slices are shared among threads.
      std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ULL ^ (uint64_t(phase_index) << 32) ^ uint64_t(k));
      std::normal_distribution<double> noise(0.0, noise_hu);
      for (int j = 0; j < volume.size.y(); ++j) {
        for (int i = 0; i < volume.size.x(); ++i) {
          const Eigen::Vector3d centre = volume.origin_m + h * Eigen::Vector3d(i, j, k);
          double value = 0;
          for (int s = 0; s < 8; ++s) {
            const Eigen::Vector3d offset = 0.25 * h * Eigen::Vector3d(s & 1 ? 1 : -1, s & 2 ? 1 : -1, s & 4 ? 1 : -1);
            value += MaterialHu(geometry, motion, state, centre + offset) / 8;
          }
          for (int f = 0; f < beads.cols(); ++f) {
            if ((centre - beads.col(f)).norm() > bead_r + h) continue;
            constexpr int kSub = 6;
            int inside = 0;
            for (int s = 0; s < kSub * kSub * kSub; ++s) {
              const Eigen::Vector3d offset =
                  h * (Eigen::Vector3d(s % kSub, (s / kSub) % kSub, s / (kSub * kSub)) + Eigen::Vector3d::Constant(0.5)) / kSub -
                  Eigen::Vector3d::Constant(0.5 * h);
              inside += (centre + offset - beads.col(f)).norm() <= bead_r;
            }
            const double fraction = double(inside) / (kSub * kSub * kSub);
            value = fraction * kBeadHu + (1 - fraction) * value;
          }
          value += noise(rng);
          volume.at(i, j, k) = static_cast<int16_t>(std::lround(std::clamp(value, -32768.0, 32767.0)));
        }
      }
    }
  });
  return volume;
}

}  // namespace dg::tools::phantom
