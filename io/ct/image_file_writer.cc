#include "io/ct/image_file_writer.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

// The system's Eigen modules before ITK's headers (docs/preop.md, "Reading and writing CT").
#include <Eigen/Dense>
#include <itkImage.h>
#include <itkImageFileWriter.h>

#include "io/ct/itk_factories.h"
#include "sim/error.h"

namespace dg::io {
namespace {

bool EndsWith(const std::string& text, const std::string& end) {
  return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}

template <typename Pixel>
void WriteAs(const CtImage& image, const std::string& path, bool compress) {
  using Volume = itk::Image<Pixel, 3>;
  auto volume = Volume::New();
  typename Volume::SizeType size;
  typename Volume::SpacingType spacing;
  typename Volume::PointType origin;
  typename Volume::DirectionType direction;
  for (int a = 0; a < 3; ++a) {
    size[a] = static_cast<typename Volume::SizeValueType>(image.size[a]);
    spacing[a] = 1e3 * image.spacing_m[a];
    origin[a] = 1e3 * image.origin_m[a];
    for (int b = 0; b < 3; ++b) direction(a, b) = image.direction(a, b);
  }
  volume->SetRegions(typename Volume::RegionType(size));
  volume->SetSpacing(spacing);
  volume->SetOrigin(origin);
  volume->SetDirection(direction);
  volume->Allocate();
  Pixel* voxels = volume->GetBufferPointer();
  constexpr double kLow = std::numeric_limits<Pixel>::lowest(), kHigh = std::numeric_limits<Pixel>::max();
  for (size_t v = 0; v < image.num_voxels(); ++v) {
    if constexpr (std::is_floating_point_v<Pixel>) {
      voxels[v] = image.values[v];
    } else {
      voxels[v] = static_cast<Pixel>(std::lround(std::clamp(static_cast<double>(image.values[v]), kLow, kHigh)));
    }
  }
  RegisterItkImageIo();
  auto writer = itk::ImageFileWriter<Volume>::New();
  writer->SetInput(volume);
  writer->SetFileName(path);
  writer->SetUseCompression(compress);
  try {
    writer->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("cannot write the image: ") + e.GetDescription(), path,
                "check that the folder exists, is writable and has space");
  }
}

}  // namespace

void WriteImageFile(const CtImage& image, const std::string& path, StoredPixel pixel, bool compress) {
  if (image.num_voxels() == 0 || image.values.size() != image.num_voxels()) {
    throw Error("the image to write is empty or its values do not fill its grid", path, "give a complete image");
  }
  bool known = false;
  for (const char* extension : {".nii.gz", ".nii", ".nrrd", ".nhdr", ".mha", ".mhd"}) known |= EndsWith(path, extension);
  if (!known) {
    throw Error("an image file's name must end in .nii.gz, .nii, .nrrd, .nhdr, .mha or .mhd", path,
                "name the file with one of those extensions (.nii.gz or .nrrd for 3D Slicer)");
  }
  switch (pixel) {
    case StoredPixel::kUInt8: return WriteAs<std::uint8_t>(image, path, compress);
    case StoredPixel::kInt16: return WriteAs<std::int16_t>(image, path, compress);
    case StoredPixel::kInt32: return WriteAs<std::int32_t>(image, path, compress);
    case StoredPixel::kFloat32: return WriteAs<float>(image, path, compress);
  }
}

}  // namespace dg::io
