#include "io/ct/displacement_field.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

// The system's Eigen modules before ITK's headers: ITK's bundled Eigen (3.3,
// same guards) then uses them instead of compiling its own against ours.
#include <Eigen/Dense>
#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkImageFileWriter.h>
#include <itkImageIOFactory.h>
#include <itkVector.h>

#include "io/ct/itk_factories.h"
#include "sim/error.h"

namespace dg::io {
namespace {

using VectorImage = itk::Image<itk::Vector<float, 3>, 3>;

}  // namespace

namespace {
constexpr double kSlack = 1e-9;  // a point on the last grid plane, up to rounding
}  // namespace

bool DisplacementField::Contains(const Eigen::Vector3d& X_S_m) const {
  const Eigen::Vector3d c = (direction * spacing_m.asDiagonal()).inverse() * (X_S_m - origin_m);
  return (c.array() >= -kSlack).all() && (c.array() <= size.cast<double>().array() - 1 + kSlack).all();
}

Eigen::Vector3d DisplacementField::SampleMm(const Eigen::Vector3d& X_S_m) const {
  const Eigen::Vector3d c = (direction * spacing_m.asDiagonal()).inverse() * (X_S_m - origin_m);
  for (int a = 0; a < 3; ++a) {
    if (!(c[a] >= -kSlack && c[a] <= size[a] - 1 + kSlack)) {
      char where[96];
      std::snprintf(where, sizeof where, "X = (%.6g, %.6g, %.6g) mm", 1e3 * X_S_m.x(), 1e3 * X_S_m.y(), 1e3 * X_S_m.z());
      throw Error("a point outside the displacement field's grid", where,
                  "sample inside the grid (its first and last points bound it)");
    }
  }
  Eigen::Vector3i lo;
  Eigen::Vector3d t;
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::clamp(static_cast<int>(std::floor(c[a])), 0, std::max(size[a] - 2, 0));
    t[a] = size[a] > 1 ? std::clamp(c[a] - lo[a], 0.0, 1.0) : 0.0;
  }
  Eigen::Vector3d u = Eigen::Vector3d::Zero();
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3i offset(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
    double weight = 1;
    for (int a = 0; a < 3; ++a) weight *= offset[a] ? t[a] : 1 - t[a];
    if (weight == 0) continue;
    const Eigen::Vector3i v = (lo + offset).cwiseMin(size - Eigen::Vector3i::Ones());
    u += weight * u_mm.col(Index(v.x(), v.y(), v.z())).cast<double>();
  }
  return u;
}

DisplacementField ZeroFieldOn(const CtImage& ct) {
  DisplacementField field;
  field.size = ct.size;
  field.spacing_m = ct.spacing_m;
  field.origin_m = ct.origin_m;
  field.direction = ct.direction;
  field.u_mm = Eigen::Matrix3Xf::Zero(3, static_cast<Eigen::Index>(ct.num_voxels()));
  return field;
}

void WriteDisplacementField(const std::string& path_mha, const DisplacementField& field, bool compress) {
  if (field.num_voxels() == 0 || static_cast<std::size_t>(field.u_mm.cols()) != field.num_voxels()) {
    throw Error("the displacement field is empty or its values do not fill its grid", path_mha,
                "give one displacement per grid point");
  }
  RegisterItkImageIo();
  auto image = VectorImage::New();
  VectorImage::SizeType size;
  VectorImage::SpacingType spacing;
  VectorImage::PointType origin;
  VectorImage::DirectionType direction;
  for (int a = 0; a < 3; ++a) {
    size[a] = static_cast<VectorImage::SizeValueType>(field.size[a]);
    spacing[a] = 1e3 * field.spacing_m[a];
    origin[a] = 1e3 * field.origin_m[a];
    for (int b = 0; b < 3; ++b) direction(a, b) = field.direction(a, b);
  }
  image->SetRegions(VectorImage::RegionType(size));
  image->SetSpacing(spacing);
  image->SetOrigin(origin);
  image->SetDirection(direction);
  image->Allocate();
  itk::Vector<float, 3>* voxels = image->GetBufferPointer();
  for (std::size_t v = 0; v < field.num_voxels(); ++v) {
    for (int a = 0; a < 3; ++a) voxels[v][a] = field.u_mm(a, static_cast<Eigen::Index>(v));
  }
  auto writer = itk::ImageFileWriter<VectorImage>::New();
  writer->SetInput(image);
  writer->SetFileName(path_mha);
  writer->SetUseCompression(compress);
  try {
    writer->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("cannot write the displacement field: ") + e.GetDescription(), path_mha,
                "check the folder exists and is writable, and the name ends in .mha");
  }
}

DisplacementField ReadDisplacementField(const std::string& path) {
  RegisterItkImageIo();
  itk::ImageIOBase::Pointer io = itk::ImageIOFactory::CreateImageIO(path.c_str(), itk::IOFileModeEnum::ReadMode);
  if (!io) throw Error("no image reader takes this file", path, "give a displacement field as .mha, .nrrd or .nii");
  auto reader = itk::ImageFileReader<VectorImage>::New();
  try {
    io->SetFileName(path);
    io->ReadImageInformation();
    if (io->GetNumberOfComponents() != 3 || io->GetNumberOfDimensions() != 3) {
      throw Error("a displacement field must be 3-D with 3 components per voxel; this file is " +
                      std::to_string(io->GetNumberOfDimensions()) + "-D with " +
                      std::to_string(io->GetNumberOfComponents()),
                  path, "give a 3-D vector image");
    }
    reader->SetImageIO(io);
    reader->SetFileName(path);
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("cannot read the displacement field: ") + e.GetDescription(), path,
                "check the file is complete");
  }
  const VectorImage& image = *reader->GetOutput();
  DisplacementField field;
  for (int a = 0; a < 3; ++a) {
    field.size[a] = static_cast<int>(image.GetLargestPossibleRegion().GetSize()[a]);
    field.spacing_m[a] = 1e-3 * image.GetSpacing()[a];
    field.origin_m[a] = 1e-3 * image.GetOrigin()[a];
    for (int b = 0; b < 3; ++b) field.direction(a, b) = image.GetDirection()(a, b);
  }
  field.u_mm.resize(3, static_cast<Eigen::Index>(field.num_voxels()));
  const itk::Vector<float, 3>* voxels = image.GetBufferPointer();
  for (std::size_t v = 0; v < field.num_voxels(); ++v) {
    for (int a = 0; a < 3; ++a) field.u_mm(a, static_cast<Eigen::Index>(v)) = voxels[v][a];
  }
  return field;
}

}  // namespace dg::io
