#include "stages/preop/segment/label_image_writer.h"

#include <algorithm>
#include <cstdint>
#include <vector>

// The system's Eigen modules before ITK's headers (see segmentation.cc).
#include <Eigen/Dense>
#include <fmt/format.h>
#include <itkImage.h>
#include <itkImageFileWriter.h>

#include "io/ct/itk_factories.h"
#include "sim/error.h"

namespace dg::stages::preop {
namespace {

using LabelImage = itk::Image<std::uint8_t, 3>;

constexpr char kExtensions[] = ".nii.gz, .nii, .nrrd, .nhdr, .mha or .mhd";

bool EndsWith(const std::string& text, const std::string& end) {
  return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}

bool KnownExtension(const std::string& path) {
  for (const char* ext : {".nii.gz", ".nii", ".nrrd", ".nhdr", ".mha", ".mhd"}) {
    if (EndsWith(path, ext)) return true;
  }
  return false;
}

bool SameGrid(const VoxelMask& a, const VoxelMask& b) {
  return a.size == b.size && a.spacing_m == b.spacing_m && a.origin_m == b.origin_m && a.direction == b.direction &&
         a.inside.size() == b.inside.size();
}

// The labels voxel by voxel: mount, then organ, then internal structures, each
// over the one before.
std::vector<std::uint8_t> Labels(const Segmentation& s, const std::string& path) {
  std::vector<std::uint8_t> labels(s.organ.num_voxels(), 0);
  auto paint = [&](const VoxelMask& mask, std::uint8_t label) {
    if (mask.inside.empty()) return;  // an absent mask (no mount)
    if (!SameGrid(mask, s.organ)) {
      throw Error(fmt::format("label {}'s mask lies on another grid than the organ's", label), path,
                  "write a segmentation from one Segment() call");
    }
    for (std::size_t v = 0; v < labels.size(); ++v) {
      if (mask.inside[v]) labels[v] = label;
    }
  };
  paint(s.mount, 2);
  paint(s.organ, 1);
  for (std::size_t i = 0; i < s.internal.size(); ++i) paint(s.internal[i], static_cast<std::uint8_t>(3 + i));
  return labels;
}

LabelImage::Pointer ToItk(const VoxelMask& grid, const std::vector<std::uint8_t>& labels) {
  LabelImage::Pointer image = LabelImage::New();
  LabelImage::SizeType size;
  LabelImage::SpacingType spacing;
  LabelImage::PointType origin;
  LabelImage::DirectionType direction;
  for (int a = 0; a < 3; ++a) {
    size[a] = static_cast<itk::SizeValueType>(grid.size[a]);
    spacing[a] = 1e3 * grid.spacing_m[a];
    origin[a] = 1e3 * grid.origin_m[a];
    for (int b = 0; b < 3; ++b) direction(a, b) = grid.direction(a, b);
  }
  image->SetRegions(LabelImage::RegionType(size));
  image->SetSpacing(spacing);
  image->SetOrigin(origin);
  image->SetDirection(direction);
  image->Allocate();
  std::copy(labels.begin(), labels.end(), image->GetBufferPointer());
  return image;
}

}  // namespace

void WriteLabelImage(const Segmentation& segmentation, const std::string& path) {
  if (!KnownExtension(path)) {
    throw Error("a label image's file name must end in " + std::string(kExtensions), path,
                "name the file with one of those extensions (.nii.gz or .nrrd for 3D Slicer)");
  }
  if (segmentation.internal.size() > 253) {
    throw Error(fmt::format("{} internal structures do not fit an 8-bit label image (labels 3..255)",
                            segmentation.internal.size()),
                path, "keep at most 253 internal structures (max_internal_structures)");
  }
  if (segmentation.organ.inside.size() != segmentation.organ.num_voxels() || segmentation.organ.num_voxels() == 0) {
    throw Error("the segmentation's organ mask is empty or does not fill its grid", path,
                "write the result of Segment()");
  }
  const LabelImage::Pointer image = ToItk(segmentation.organ, Labels(segmentation, path));
  io::RegisterItkImageIo();
  try {
    auto writer = itk::ImageFileWriter<LabelImage>::New();
    writer->SetFileName(path);
    writer->SetInput(image);
    writer->SetUseCompression(true);
    writer->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("could not write the label image: ") + e.GetDescription(), path,
                "check that the folder exists and is writable");
  }
}

}  // namespace dg::stages::preop
