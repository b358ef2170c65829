#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/metaimage.h"
#include "stages/register/fiducial_motion.h"

namespace dg::stages {

struct BeadDetectionOptions {
  // Beads are the voxels above this CT number: metal or ceramic markers
  // (thousands of HU) above soft tissue, contrast and plastic (hundreds).
  double threshold_hu = 1500;
  // Centroid weights are CT numbers above this level, so that the rim's
  // partial-volume voxels count by the fraction of bead they hold while the
  // surrounding tissue counts for nothing.
  double background_hu = 200;
  int min_voxels = 2;  // smaller components are noise

  std::string Validate() const;  // empty when valid
};

// The beads of one CT volume in the scan frame S, metres: 26-connected
// components above the threshold, each located by the intensity-weighted
// centroid of itself and its one-voxel rim. In the order found (slice by slice).
// @throws dg::Error for invalid options.
std::vector<Eigen::Vector3d> DetectBeads(const io::VolumeI16& volume, const BeadDetectionOptions& options);

// The beads of every phase of a 4D CT (volume k at phase k / P), as fiducial
// motion: phase 0's beads in the order found, each later phase's matched to
// the nearest bead of the phase before (beads move far less between phases
// than they are apart).
// @throws dg::Error naming the volume whose bead count differs from phase 0's
//   or whose beads do not match one to one, or with no beads.
FiducialMotion DetectBeadMotion(const std::vector<std::string>& ct_volumes, const BeadDetectionOptions& options);

}  // namespace dg::stages
