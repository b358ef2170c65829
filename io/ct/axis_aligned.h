#pragma once

#include <string>

#include <Eigen/Core>

#include "io/ct/ct_image.h"

namespace dg::io {

// How the voxel axes of a direction matrix lie in the scan frame S: voxel axis
// a is nearest to S axis `axis[a]`, pointing along it (+1) or against it (-1).
struct AxisMatch {
  Eigen::Vector3i axis = Eigen::Vector3i(0, 1, 2);
  Eigen::Vector3i sign = Eigen::Vector3i::Ones();
  double largest_angle_deg = 0;  // the largest angle between a voxel axis and its S axis
  bool is_signed_permutation = true;  // every voxel axis along its S axis (within 1e-6)

  // The S axes the voxel axes point to, as letters of LPS: "LPS" for the
  // identity, "RAS" for diag(-1, -1, 1), "PLS" for x and y swapped.
  std::string Code() const;
};

// The assignment of voxel axes to S axes that keeps them closest (the largest
// sum of |cosines| over the six permutations).
AxisMatch MatchAxes(const Eigen::Matrix3d& direction);

enum class Interpolation { kLinear, kNearest };

// The image on a grid of S's axes (direction the identity), in the same
// frame S, so a physical point keeps its value:
//  - direction a signed permutation (a flip or exchange of axes, as RAS
//    NIfTI or a sagittal series): the voxels are moved, not interpolated;
//    the origin is the physical position of the new voxel (0, 0, 0);
//  - oblique: resampled onto the grid that covers the bounding box of the
//    voxel centres, voxel axis a's spacing along its nearest S axis,
//    `interpolation` inside the voxels' extent (index within -1/2 of the
//    first and last voxel) and `outside_value` beyond; a warning in the "io"
//    log names the angle and the source.
// Records what was done in reoriented_from ("" when already aligned, the
// axis code such as "RAS", or "oblique 12.3 deg") and oblique_angle_deg.
CtImage OnAxisAlignedGrid(CtImage image, Interpolation interpolation, float outside_value);

}  // namespace dg::io
