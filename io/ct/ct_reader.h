#pragma once

#include <functional>
#include <string>
#include <vector>

#include "io/ct/ct_image.h"

namespace dg::io {

// What the values of a CT are, and so how they are checked.
enum class CtIntensity {
  kHu,     // Hounsfield units (the file's rescale applied), checked as HU
  kScale,  // HU = intensity_slope * stored value + intensity_intercept, then checked as HU
  kNotHu,  // taken as stored, not checked; the image is marked values_are_hu = false
};

struct CtReadOptions {
  // Phases by SeriesInstanceUID, searched in every input folder, in cycle
  // order. Empty: every series of the inputs.
  std::vector<std::string> series_uids;
  // Called after each phase is read (index from 0, of count). Empty: a line in
  // the "io" log per phase.
  std::function<void(const CtImage& phase, int index, int count)> progress;
  CtIntensity intensity = CtIntensity::kHu;
  // With kScale only: the stored value v (the file's own rescale applied, for
  // DICOM) becomes intensity_slope * v + intensity_intercept HU.
  double intensity_slope = 1;
  double intensity_intercept = 0;

  std::string Validate() const;  // empty when valid
};

// Reads one CT phase through ITK: an image file (.nii, .nii.gz, .nrrd, .nhdr,
// .mhd, .mha, compressed or not, any scalar pixel type; a single DICOM file)
// or a folder holding exactly one DICOM series. The frame S is the one ITK
// reports (DICOM's patient frame, LPS; NIfTI's converted from RAS to LPS),
// lengths converted from millimetres to metres; values as float with DICOM's
// rescale slope and intercept applied (HU). For a DICOM series the voxel axes
// i, j are ImageOrientationPatient's row and column directions and k their
// cross product, the slices sorted along it.
// The image returned lies on S's axes (direction the identity), the file's
// voxels put there by OnAxisAlignedGrid (io/ct/axis_aligned.h): moved exactly
// for a flip or exchange of axes, resampled linearly (-1024 HU outside; with
// kNotHu the image's minimum) for an oblique one, with a warning.
// With options.intensity kHu or kScale the values must look like a CT in HU
// (CheckHounsfield). options.series_uids and progress are not used here.
// @throws dg::Error (naming the path) for a missing path, a file no reader
//   takes, a 4-D or vector image, a folder with no series or several (listing
//   their UIDs and descriptions), a DICOM modality other than CT, unevenly
//   spaced slices (a slice missing), values that are not HU, invalid options,
//   and what ITK reports for a damaged file.
CtImage ReadCtImage(const std::string& path, const CtReadOptions& options = {});

// As ReadCtImage, for a label map: any modality (a DICOM series of any
// modality, or an image file), values as stored and not checked
// (values_are_hu false); an oblique grid is resampled by nearest voxel, 0
// outside.
CtImage ReadLabelMap(const std::string& path);

// Refuses values that are not a CT in HU. A CT's field of view holds air
// (-1000 HU), lung (-900..-500) or fat (-100): at least 0.1% of its voxels lie
// below -200 HU. Its body is soft tissue: the median of the voxels above
// -200 HU lies in [-150, 500] HU (real CTs: -19 abdomen, 31 and 49 body
// slices; 400 would be contrast-filled blood). An 8-bit image (0..255), a CT
// stored without its rescale (air at 0) and MR intensities fail one or the
// other. An image with no voxel above -200 HU (all air) is not judged on its
// tissue.
// @throws dg::Error naming `ct.source`, the range of values, the figures
//   above, the modality when known, and the fixes (--intensity-scale
//   SLOPE,INTERCEPT, --not-hu, or a CT in HU).
void CheckHounsfield(const CtImage& ct);

// The phases of a 4D CT, in cycle order, from
//  (a) one folder holding every phase as a DICOM series of its own (in it,
//      or when it holds none, in its subfolders, one level down), ordered
//      by the first cardiac-phase tag every series carries (see OrderPhases:
//      NominalPercentageOfCardiacPhase, a percentage in SeriesDescription,
//      TemporalPositionIdentifier, then TriggerTime);
//  (b) one folder per phase, each holding one series, in the order given;
//  (c) one image file per phase, in the order given;
// or, with options.series_uids, the series of those UIDs in the order given.
// In (b), (c) and by UID the order given is the cycle's: when every phase
// carries a phase tag the tags must agree with it. Except for phases chosen
// by UID, a cycle with a phase missing between evenly spaced tags is an error. Each phase's
// cycle_fraction is set when its tags tell it (a percentage, a temporal
// position of NumberOfTemporalPositions, a trigger time with HeartRate).
// @throws dg::Error as ReadCtImage does, and for invalid options, phases of
//   different size, spacing, origin or orientation (naming both phases and
//   their values), a folder whose series are not the phases of one cycle
//   (listing each series' UID, description and tags), a missing phase (which
//   one), a series UID found in no input (listing the UIDs there are), and
//   phases given out of cycle order.
// Each phase is read as ReadCtImage reads it, with options.intensity.
std::vector<CtImage> ReadCtPhases(const std::vector<std::string>& inputs, const CtReadOptions& options);

}  // namespace dg::io
