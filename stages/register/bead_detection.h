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
  // The beads' size range, as the diameter of a sphere of the component's
  // volume (voxels above the threshold): a calcification or a contrast-filled
  // vessel above the threshold is far larger than a marker bead.
  double min_diameter_mm = 0;
  double max_diameter_mm = 6;
  // Only components whose centroid lies in this box of the scan frame S
  // (metres) are beads; an empty box (min > max, the default) is all of S.
  Eigen::Vector3d roi_min_m = Eigen::Vector3d::Constant(1);
  Eigen::Vector3d roi_max_m = Eigen::Vector3d::Constant(-1);

  bool HasRoi() const { return (roi_min_m.array() <= roi_max_m.array()).all(); }
  std::string Validate() const;  // empty when valid
  std::string Describe() const;  // "above 1500 HU, 0-6 mm across[, in (..)-(..) mm]"
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
// @throws dg::Error with no beads, or when a phase's bead count differs from
//   phase 0's or its beads do not match one to one: the error lists every
//   phase's count and phase 0's beads, so the threshold, size range or region
//   can be set from it.
FiducialMotion DetectBeadMotion(const std::vector<std::string>& ct_volumes, const BeadDetectionOptions& options);

// The beads of each volume, as DetectBeads finds them, one list per volume.
std::vector<std::vector<Eigen::Vector3d>> DetectBeadsInPhases(const std::vector<std::string>& ct_volumes,
                                                              const BeadDetectionOptions& options);

// The fiducial motion of beads found per phase (DetectBeadsInPhases), matched
// as DetectBeadMotion does. Zero beads in every phase is not an error here: the
// result then has no fiducials.
// @throws dg::Error as DetectBeadMotion, but for no beads.
FiducialMotion MatchBeadsAcrossPhases(const std::vector<std::vector<Eigen::Vector3d>>& beads,
                                      const std::vector<std::string>& ct_volumes, const BeadDetectionOptions& options);

}  // namespace dg::stages
