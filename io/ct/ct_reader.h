#pragma once

#include <functional>
#include <string>
#include <vector>

#include "io/ct/ct_image.h"

namespace dg::io {

// Reads one CT phase through ITK: an image file (.nii, .nii.gz, .nrrd, .nhdr,
// .mhd, .mha, compressed or not, any scalar pixel type; a single DICOM file)
// or a folder holding exactly one DICOM series. The frame is the one ITK
// reports (DICOM's patient frame, LPS; NIfTI's converted from RAS to LPS),
// lengths converted from millimetres to metres, direction cosines kept; values
// as float with DICOM's rescale slope and intercept applied (HU). For a DICOM
// series the voxel axes i, j are ImageOrientationPatient's row and column
// directions and k their cross product, the slices sorted along it.
// @throws dg::Error (naming the path) for a missing path, a file no reader
//   takes, a 4-D or vector image, a folder with no series or several (listing
//   their UIDs and descriptions), a DICOM modality other than CT, unevenly
//   spaced slices (a slice missing), and what ITK reports for a damaged file.
CtImage ReadCtImage(const std::string& path);

// As ReadCtImage, for a label map: any modality (a DICOM series of any
// modality, or an image file), values as stored.
CtImage ReadLabelMap(const std::string& path);

struct CtReadOptions {
  // Phases by SeriesInstanceUID, searched in every input folder, in cycle
  // order. Empty: every series of the inputs.
  std::vector<std::string> series_uids;
  // Called after each phase is read (index from 0, of count). Empty: a line in
  // the "io" log per phase.
  std::function<void(const CtImage& phase, int index, int count)> progress;

  std::string Validate() const;  // empty when valid
};

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
std::vector<CtImage> ReadCtPhases(const std::vector<std::string>& inputs, const CtReadOptions& options);

}  // namespace dg::io
