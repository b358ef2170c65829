#pragma once

#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "tools/phantom/real_ct_motion.h"

namespace dg::tools::phantom {

// `dynaguide phantom --ct CT`: a 4D CT with exact truth made from a real CT
// by warping it with RealCtMotion (docs/commands/phantom.md, "A phantom from
// a real CT").
struct RealCtPhantomOptions {
  std::string ct;              // any file io::ReadCtImage reads, or a folder of one DICOM series
  std::string labels;          // optional label map on the CT's grid
  int organ_label = 0;         // the label the motion centres on; 0: every non-zero label
  std::string out_dir;
  RealCtMotion::Kind motion = RealCtMotion::Kind::kCardiac;
  int phases = 10;
  double amplitude_mm = 4;
  double period_s = 0;         // one cycle; 0: 1 s cardiac (60 bpm), 4 s respiratory
  uint64_t seed = 1;           // draws the motion's shape (twist, shortening, expansion) and names the UIDs
  std::string ct_format = "both";  // mhd (ct/phase_NN.mhd), dicom (ct/dicom/phase_NN/) or both
  bool progress = true;        // a line per phase on stderr

  std::string Validate() const;  // empty when valid
  double Period_s() const;
};

struct RealCtPhantomSummary {
  std::string out_dir;
  Eigen::Vector3i size = Eigen::Vector3i::Zero();
  int phases = 0;
  double window_mm = 0;
  Eigen::Vector3d centre_S_mm = Eigen::Vector3d::Zero();
  double max_displacement_mm = 0;  // over the grid and the phases
  double min_jacobian = 1;         // over space and the phases
  std::string labels_file;         // empty without --labels
  double wall_s = 0;

  std::string Describe() const;
};

// Reads the CT (and labels), warps it into opts.phases phases, phase k at
// cycle fraction k / phases, and writes into out_dir:
//   ct/dicom/phase_NN/   a DICOM CT series per phase (one study; temporal
//                        position, nominal cardiac percentage, trigger time)
//   ct/phase_NN.mhd      the same phases as MetaImage (int16 HU)
//   truth/dvf_phase_NN.mha  u(X) in mm: X of phase 0 is at X + u(X) in phase NN
//   labels.nii.gz        the label map on the CT's grid (with --labels)
//   phantom.json         the source, the motion and its parameters
// Every phase, phase 0 included, is formed alike, as a scanner reconstructs
// each: phase k's image is I_k(x) = G * I_0(X) with X + u_k(X) = x, the CT
// as read blurred by a Gaussian point-spread of 0.5 voxel and sampled through
// a cubic B-spline, the grid's edge voxels repeated outside it. The grid is the CT's as read, its slice
// axis reversed when the direction is left-handed (DICOM's slice axis is the
// orientation's normal). Parallel over slices.
// @throws dg::Error for invalid options, an unreadable CT or label map, a label
//   map on another grid or with no voxel of the organ's label, a motion whose
//   Jacobian determinant falls to 0.5 or below (naming the phase and the
//   amplitude), and files that cannot be written.
RealCtPhantomSummary GenerateRealCtPhantom(const RealCtPhantomOptions& options);

}  // namespace dg::tools::phantom
