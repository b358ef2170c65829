#pragma once

#include <cstdint>

#include <Eigen/Core>

#include "io/metaimage.h"
#include "tools/phantom/heart_geometry.h"
#include "tools/phantom/heart_motion.h"
#include "tools/phantom/phantom_spec.h"

namespace dg::tools::phantom {

// CT numbers (HU) of the phantom's materials.
inline constexpr int16_t kAirHu = -1000, kFatHu = -100, kTissueHu = 40, kChamberHu = 250, kMountHu = 500, kBeadHu = 3000;

// The voxel grid of the 4D CT: covers the phantom at any phase of its motion,
// with a margin, and the top of the mount.
io::VolumeI16 MakeCtGrid(const PhantomSpec& spec);

// One phase of the 4D CT: each voxel the mean of 2x2x2 samples mapped back to
// the reference configuration (air, tissue, vessel fat, chamber or mount), and the beads
// (spheres of SurfaceAssets::kBeadRadius_m around the deformed fiducials)
// blended in by the fraction of 6x6x6 samples they cover, so that their
// intensity-weighted centroids fall on the fiducials; then Gaussian noise.
// Deterministic for (seed, phase_index) whatever the thread count.
io::VolumeI16 SynthesizeCtPhase(const io::VolumeI16& grid, const HeartGeometry& geometry, const HeartMotion& motion,
                                const MotionState& state, const Eigen::Matrix3Xd& fiducials_S, double noise_hu,
                                uint64_t seed, int phase_index);

}  // namespace dg::tools::phantom
