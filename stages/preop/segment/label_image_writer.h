#pragma once

#include <string>

#include "stages/preop/segment/segmentation.h"

namespace dg::stages::preop {

// Writes a segmentation as one label image on its CT's grid, as 3D Slicer
// and ITK-SNAP open one: unsigned 8-bit, 0 background, 1 the organ, 2 the
// mount, 3, 4, ... the internal structures in their order. A voxel in
// several masks takes the internal structure's label, then the organ's, then
// the mount's. The format follows the extension: .nii.gz, .nii (NIfTI),
// .nrrd, .nhdr (NRRD), .mha, .mhd (MetaImage); compressed where the format
// allows. Origin, spacing and direction are the grid's, in millimetres in
// the file (S as ITK writes it: NIfTI's RAS converted from LPS).
// @throws dg::Error for another extension, more than 253 internal structures,
//   masks on different grids, and what ITK reports (a folder that cannot be
//   written, naming the path).
void WriteLabelImage(const Segmentation& segmentation, const std::string& path);

}  // namespace dg::stages::preop
