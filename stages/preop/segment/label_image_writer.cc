#include "stages/preop/segment/label_image_writer.h"

#include <cstdint>
#include <vector>

#include <fmt/format.h>

#include "io/ct/image_file_writer.h"
#include "sim/error.h"

namespace dg::stages::preop {
namespace {

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

}  // namespace

void WriteLabelImage(const Segmentation& segmentation, const std::string& path) {
  if (segmentation.internal.size() > 253) {
    throw Error(fmt::format("{} internal structures do not fit an 8-bit label image (labels 3..255)",
                            segmentation.internal.size()),
                path, "keep at most 253 internal structures (max_internal_structures)");
  }
  if (segmentation.organ.inside.size() != segmentation.organ.num_voxels() || segmentation.organ.num_voxels() == 0) {
    throw Error("the segmentation's organ mask is empty or does not fill its grid", path,
                "write the result of Segment()");
  }
  io::CtImage labels;
  labels.size = segmentation.organ.size;
  labels.spacing_m = segmentation.organ.spacing_m;
  labels.origin_m = segmentation.organ.origin_m;
  labels.direction = segmentation.organ.direction;
  const std::vector<std::uint8_t> values = Labels(segmentation, path);
  labels.values.assign(values.begin(), values.end());
  io::WriteImageFile(labels, path, io::StoredPixel::kUInt8);
}

}  // namespace dg::stages::preop
