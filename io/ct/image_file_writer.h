#pragma once

#include <string>

#include "io/ct/ct_image.h"

namespace dg::io {

// How the values are stored in the file.
enum class StoredPixel { kUInt8, kInt16, kInt32, kFloat32 };

// Writes an image in the format ITK picks from the name (.nii.gz, .nii,
// .nrrd, .nhdr, .mha, .mhd), spacing and origin in millimetres and the
// direction kept (NIfTI's RAS converted from LPS by ITK), so ReadCtImage and
// ReadLabelMap read back the same grid: a CT as int16 HU, a label map as
// uint8 (3D Slicer's segmentations) or int32, any image as float32. Values
// are rounded and clamped to an integer type. Compressed when the format allows and `compress`.
// @throws dg::Error for an image whose values do not fill its grid, another
//   extension, or a file ITK cannot write.
void WriteImageFile(const CtImage& image, const std::string& path, StoredPixel pixel, bool compress = true);

}  // namespace dg::io
