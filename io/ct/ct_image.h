#pragma once

#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/metaimage.h"

namespace dg::io {

// One phase of a CT (or a label map on a CT's grid) in the scan frame S: the
// image's physical frame (DICOM patient coordinates, LPS; a MetaImage's or
// NIfTI's physical frame as ITK reads it), in metres. Voxel (i, j, k) has its
// centre at origin_m + direction * (spacing_m .* (i, j, k)) and its value at
// values[i + size.x * (j + size.y * k)] (x fastest). CT values are in HU, the
// file's rescale slope and intercept applied; a label map's values are its
// labels. The readers (io/ct/ct_reader.h) return the direction the identity,
// the file's grid reoriented or resampled as reoriented_from says.
struct CtImage {
  Eigen::Vector3i size = Eigen::Vector3i::Zero();
  Eigen::Vector3d spacing_m = Eigen::Vector3d::Constant(1e-3);
  Eigen::Vector3d origin_m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();  // columns: the voxel axes i, j, k in S
  std::vector<float> values;
  std::string source;          // the file or folder it was read from, for messages
  std::string series_uid;      // DICOM's SeriesInstanceUID; empty for other formats
  std::string modality;        // DICOM's Modality (0008,0060); empty for other formats
  double cycle_fraction = std::numeric_limits<double>::quiet_NaN();  // the phase in [0, 1) when the file says it
  // What the reader did to put the file's voxels on S's axes: "" (they were),
  // the file's axis code for a lossless flip or exchange ("RAS": voxel axes
  // along -x, -y, +z of LPS), or "oblique 12.3 deg" when resampled.
  std::string reoriented_from;
  double oblique_angle_deg = 0;  // the largest angle between a file's voxel axis and its S axis, when resampled
  // False when the values are not known to be HU: read as stored on request
  // (CtIntensity::kNotHu), or a label map. Automatic segmentation needs HU.
  bool values_are_hu = true;

  // Everything but the values: a grid to keep without its voxels' memory (a
  // copy with its values cleared would keep their capacity).
  CtImage GridOnly() const {
    CtImage grid;
    grid.size = size;
    grid.spacing_m = spacing_m;
    grid.origin_m = origin_m;
    grid.direction = direction;
    grid.source = source;
    grid.series_uid = series_uid;
    grid.modality = modality;
    grid.cycle_fraction = cycle_fraction;
    grid.reoriented_from = reoriented_from;
    grid.oblique_angle_deg = oblique_angle_deg;
    grid.values_are_hu = values_are_hu;
    return grid;
  }

  std::size_t num_voxels() const { return static_cast<std::size_t>(size.x()) * size.y() * size.z(); }
  std::size_t Index(int i, int j, int k) const {
    return static_cast<std::size_t>(i) + size.x() * (static_cast<std::size_t>(j) + static_cast<std::size_t>(size.y()) * k);
  }
  float at(int i, int j, int k) const { return values[Index(i, j, k)]; }
  Eigen::Vector3d PointOf(double i, double j, double k) const {
    return origin_m + direction * spacing_m.cwiseProduct(Eigen::Vector3d(i, j, k));
  }
};

// An axis-aligned volume (such as one read by ReadMetaImage) as a CtImage.
template <typename T>
CtImage ToCtImage(const Volume<T>& volume, std::string source) {
  CtImage image;
  image.size = volume.size;
  image.spacing_m = volume.spacing_m;
  image.origin_m = volume.origin_m;
  image.values.assign(volume.values.begin(), volume.values.end());
  image.source = std::move(source);
  return image;
}

}  // namespace dg::io
