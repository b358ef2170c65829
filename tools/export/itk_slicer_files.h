#pragma once

#include <string>

#include <Eigen/Core>

namespace dg::tools {

// Writes the affine map x -> T_mm x (millimetres) as an ITK transform file
// through ITK's own writer (itk::TransformFileWriterTemplate<double>): one
// AffineTransform_double_3_3 with a zero centre, its matrix the upper 3x3 of
// T_mm and its translation the last column, in ITK's text format (.tfm or
// .txt), each number printed to read back as the same double. ITK, and so Slicer, read
// the map in the resampling sense: from the fixed space to the moving space.
// @throws dg::Error naming the file when ITK cannot write it or the extension
//   is neither of those.
void WriteItkAffineTransform(const std::string& path, const Eigen::Matrix4d& T_mm);

// The geometry ITK reports for an image: millimetres, its physical frame.
struct ImageGeometryMm {
  Eigen::Vector3i size = Eigen::Vector3i::Zero();
  Eigen::Vector3d spacing_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d origin_mm = Eigen::Vector3d::Zero();
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();
};

// Reads a 3-D image through ITK (MetaImage, NRRD, NIfTI) and writes it as
// MetaImage (`out_mhd` and a .raw of its stem beside it) through ITK: the
// same voxels, spacing, origin and direction cosines. Voxels of 8- or 16-bit
// integers and float keep their type; other types are written as float.
// Returns the geometry written.
// @throws dg::Error naming the file ITK cannot read or write.
ImageGeometryMm RewriteAsMetaImage(const std::string& image, const std::string& out_mhd);

}  // namespace dg::tools
