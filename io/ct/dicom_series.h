#pragma once

#include <string>
#include <vector>

#include "io/ct/phase_order.h"

namespace dg::io {

// One DICOM series found in a folder: its files in slice order (GDCM's: along
// the normal of ImageOrientationPatient) and its first file's tags.
struct DicomSeries {
  std::string folder;
  std::string uid;        // SeriesInstanceUID
  std::string modality;   // Modality (0008,0060), e.g. CT or MR
  std::vector<std::string> files;
  PhaseTags tags;         // where = the folder
};

// The DICOM series of a folder (not its subfolders), by SeriesInstanceUID
// alone: a series holding several volumes stays one series (the reader
// rejects it by its repeated slice positions). Files that are not DICOM are
// passed over, as GDCM does.
// @throws dg::Error when the folder cannot be scanned.
std::vector<DicomSeries> ListDicomSeries(const std::string& folder);

// The tags of one DICOM file that this library reads: modality and phase.
// @throws dg::Error naming the file when it is not a readable DICOM file.
DicomSeries ReadDicomFileTags(const std::string& file);

// "UID 'description' (tags)" of each series, for messages.
std::string DescribeSeries(const std::vector<DicomSeries>& series);

}  // namespace dg::io
