#include "tools/phantom/real_ct_image_file.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

// The system's Eigen modules before ITK's headers: ITK's bundled Eigen (3.3,
// same guards) then uses them instead of compiling its own against ours.
#include <Eigen/Dense>
#include <itkImage.h>
#include <itkImageFileWriter.h>

#include "io/ct/itk_factories.h"
#include "sim/error.h"

namespace dg::tools::phantom {
namespace {

// `image`'s values, rounded and clamped to Pixel, written through ITK.
template <typename Pixel>
void WriteAs(const io::CtImage& image, const std::string& path, bool compress) {
  if (image.num_voxels() == 0 || image.values.size() != image.num_voxels()) {
    throw Error("the image to write is empty or its values do not fill its grid", path, "give a complete image");
  }
  io::RegisterItkImageIo();
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
    voxels[v] = static_cast<Pixel>(std::lround(std::clamp(static_cast<double>(image.values[v]), kLow, kHigh)));
  }
  auto writer = itk::ImageFileWriter<Volume>::New();
  writer->SetInput(volume);
  writer->SetFileName(path);
  writer->SetUseCompression(compress);
  try {
    writer->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("cannot write the image: ") + e.GetDescription(), path,
                "check the folder is writable and has space, and the name ends in .nii.gz, .nrrd, .mhd or .mha");
  }
}

}  // namespace

void WriteCtImageFile(const io::CtImage& ct, const std::string& path) {
  WriteAs<int16_t>(ct, path, false);  // as the phantom's MetaImages: raw, nothing to decode
}

void WriteLabelMapFile(const io::CtImage& labels, const std::string& path) {
  for (const float label : labels.values) {
    if (label != std::round(label) || std::abs(label) > 2e9f) {
      throw Error("a label map value " + std::to_string(label) + " is not an integer label", labels.source,
                  "give a label map of integer labels (3D Slicer's or TotalSegmentator's segmentation export)");
    }
  }
  WriteAs<int32_t>(labels, path, true);
}

}  // namespace dg::tools::phantom
