#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace dg::io {

// A 3-D image on a regular, axis-aligned grid in the scan frame S. Voxel
// (i, j, k) has its centre at origin_m + (i, j, k) .* spacing_m and its value
// at values[i + size.x * (j + size.y * k)] (x fastest, as MetaImage stores it).
// Volumes of int16 (CT numbers in HU), uint8 (labels) and float are read and
// written.
template <typename T>
struct Volume {
  Eigen::Vector3i size = Eigen::Vector3i::Zero();
  Eigen::Vector3d spacing_m = Eigen::Vector3d::Constant(1e-3);
  Eigen::Vector3d origin_m = Eigen::Vector3d::Zero();
  std::vector<T> values;

  std::size_t num_voxels() const {
    return static_cast<std::size_t>(size.x()) * size.y() * size.z();
  }
  std::size_t Index(int i, int j, int k) const {
    return static_cast<std::size_t>(i) +
           size.x() * (static_cast<std::size_t>(j) + static_cast<std::size_t>(size.y()) * k);
  }
  T& at(int i, int j, int k) { return values[Index(i, j, k)]; }
  const T& at(int i, int j, int k) const { return values[Index(i, j, k)]; }
};

using VolumeI16 = Volume<std::int16_t>;
using VolumeU8 = Volume<std::uint8_t>;
using VolumeF32 = Volume<float>;

// Writes MetaImage: the header `mhd_path` (ending .mhd) and the voxels in a
// .raw file of the same stem beside it, uncompressed little-endian
// (MET_SHORT, MET_UCHAR or MET_FLOAT). The header gives spacing and offset in
// millimetres, as 3D Slicer, ITK and ParaView take them, an identity
// TransformMatrix and orientation RAI.
// @pre volume.values.size() == volume.num_voxels()
// @throws dg::Error when a file cannot be written.
template <typename T>
void WriteMetaImage(const std::string& mhd_path, const Volume<T>& volume);

// A MetaImage's grid from its header alone (the voxels are not read), in
// metres as Volume holds it; values stays empty.
// @throws dg::Error as ReadMetaImage does for the header.
Volume<std::uint8_t> ReadMetaImageGrid(const std::string& mhd_path);

// Reads a 3-D single-channel MetaImage header (keys in any order; keys that
// do not change the voxels, such as comments, ignored) and its uncompressed
// data file. T must match the file's ElementType.
// @throws dg::Error naming the file and line (or key) of a missing, malformed
//   or unsupported entry, and a data file of the wrong size.
template <typename T>
Volume<T> ReadMetaImage(const std::string& mhd_path);

}  // namespace dg::io
