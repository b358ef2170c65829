#pragma once

#include <cstddef>
#include <string>

#include <Eigen/Core>

#include "io/ct/ct_image.h"

namespace dg::io {

// A displacement field on a grid in the scan frame S, as ITK and 3D Slicer
// take one: at the grid point X, u(X) in millimetres along S's axes (not the
// voxel axes). As an ITK displacement-field transform it maps a point X of
// the fixed image to X + u(X) in the moving one. The grid is a CtImage's
// (voxel (i, j, k) at origin_m + direction * (spacing_m .* (i, j, k)), x fastest).
struct DisplacementField {
  Eigen::Vector3i size = Eigen::Vector3i::Zero();
  Eigen::Vector3d spacing_m = Eigen::Vector3d::Constant(1e-3);
  Eigen::Vector3d origin_m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();
  Eigen::Matrix3Xf u_mm;  // column v: voxel v

  std::size_t num_voxels() const { return static_cast<std::size_t>(size.x()) * size.y() * size.z(); }
  std::size_t Index(int i, int j, int k) const {
    return static_cast<std::size_t>(i) + size.x() * (static_cast<std::size_t>(j) + static_cast<std::size_t>(size.y()) * k);
  }
  Eigen::Vector3d PointOf(int i, int j, int k) const {
    return origin_m + direction * spacing_m.cwiseProduct(Eigen::Vector3d(i, j, k));
  }
  // Whether X lies within the grid's bounding points, where SampleMm samples.
  bool Contains(const Eigen::Vector3d& X_S_m) const;
  // u at X by trilinear interpolation of the grid points around it, mm.
  // @throws dg::Error when X lies outside the grid's bounding points.
  Eigen::Vector3d SampleMm(const Eigen::Vector3d& X_S_m) const;
};

// A zero field on the grid of `ct`.
DisplacementField ZeroFieldOn(const CtImage& ct);

// Writes a 3-component float MetaImage (.mha, one file; zlib-compressed
// unless compress is false) with spacing, origin and direction in
// millimetres, as ITK's displacement-field transforms and 3D Slicer read it.
// @throws dg::Error for a field whose values do not fill its grid, or a file
//   that cannot be written.
void WriteDisplacementField(const std::string& path_mha, const DisplacementField& field, bool compress = true);

// Reads a 3-component image (any format ITK reads) as a displacement field in mm.
// @throws dg::Error naming the file when it cannot be read or is not 3-D with
//   3 components.
DisplacementField ReadDisplacementField(const std::string& path);

}  // namespace dg::io
