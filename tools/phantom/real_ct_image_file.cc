#include "tools/phantom/real_ct_image_file.h"

#include <cmath>
#include <string>

#include "io/ct/image_file_writer.h"
#include "sim/error.h"

namespace dg::tools::phantom {

void WriteCtImageFile(const io::CtImage& ct, const std::string& path) {
  io::WriteImageFile(ct, path, io::StoredPixel::kInt16, false);  // as the phantom's MetaImages: raw, nothing to decode
}

void WriteLabelMapFile(const io::CtImage& labels, const std::string& path) {
  for (const float label : labels.values) {
    if (label != std::round(label) || std::abs(label) > 2e9f) {
      throw Error("a label map value " + std::to_string(label) + " is not an integer label", labels.source,
                  "give a label map of integer labels (3D Slicer's or TotalSegmentator's segmentation export)");
    }
  }
  io::WriteImageFile(labels, path, io::StoredPixel::kInt32);
}

}  // namespace dg::tools::phantom
