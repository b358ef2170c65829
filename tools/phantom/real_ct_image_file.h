#pragma once

#include <string>

#include "io/ct/ct_image.h"

namespace dg::tools::phantom {

// Writes `image` as an integer image file, in the format ITK's writers pick
// from the name (.nii.gz, .nrrd, .mhd, .mha), spacing and origin in
// millimetres and the direction kept, so io::ReadCtImage and io::ReadLabelMap
// read back the same grid. Values are rounded; a CT as int16 HU (clamped to
// int16's range, as the phantom's MetaImages), a label map as int32.
// @throws dg::Error for an empty image, a label that is not an integer, or a
//   file that cannot be written.
void WriteCtImageFile(const io::CtImage& ct, const std::string& path);
void WriteLabelMapFile(const io::CtImage& labels, const std::string& path);

}  // namespace dg::tools::phantom
