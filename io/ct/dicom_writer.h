#pragma once

#include <limits>
#include <string>
#include <string_view>

#include "io/ct/ct_image.h"

namespace dg::io {

// What a DICOM CT series says besides its voxels. UIDs are given, not drawn
// at random, so that the same data writes the same bytes: DeterministicUid
// makes them from a text.
struct DicomSeriesInfo {
  std::string patient_id, patient_name;  // PatientName as DICOM writes it, e.g. "Phantom^Heart"
  std::string study_uid, series_uid;
  std::string frame_of_reference_uid;    // shared by the phases of one scan; empty: derived from study_uid
  std::string study_description, series_description;
  int series_number = 1;
  // YYYYMMDD: the study's, series', content's and instance creation's date
  // (times 000000). Empty: GDCM writes the current date and time as the
  // instance's creation, and the bytes differ from one run to the next.
  std::string date;
  // The series' place in a 4D CT; 0 / NaN for a CT of no cycle.
  int temporal_position = 0;             // TemporalPositionIdentifier, from 1
  int temporal_positions = 0;            // NumberOfTemporalPositions
  double cycle_fraction = std::numeric_limits<double>::quiet_NaN();  // NominalPercentageOfCardiacPhase / 100
  double trigger_time_ms = std::numeric_limits<double>::quiet_NaN(); // TriggerTime, after the R wave
  double heart_rate_bpm = std::numeric_limits<double>::quiet_NaN();  // HeartRate

  std::string Validate() const;  // empty when valid
};

// A valid DICOM UID (PS3.5 B.2: "2.25." and a 128-bit integer in decimal, the
// form that needs no registered root) made from `text` by a fixed hash: the
// same text gives the same UID, different texts practically never the same.
std::string DeterministicUid(std::string_view text);

// Writes `ct` as a DICOM CT series into `folder` (created): one file per
// slice k, slice_NNNN.dcm, CT Image Storage, explicit VR little endian.
// Pixels int16 with RescaleSlope 1 and RescaleIntercept -1024 (stored = HU +
// 1024, as scanners write), HU rounded and clamped to [-32768, 31743].
// ImagePositionPatient of slice k is ct.PointOf(0, 0, k), ImageOrientation-
// Patient the direction's first two columns, PixelSpacing and SliceThickness
// the spacing, all in millimetres; SOPInstanceUID is series_uid.(k+1). Read
// back (ReadCtImage), the voxels and the frame are the same when the
// direction is right-handed (a left-handed one comes back with k reversed,
// DICOM's slice axis being the orientation's normal).
// Deterministic when info.date is given: the same image and info write the same bytes.
// @throws dg::Error for an invalid info, an empty image, or a file that
//   cannot be written.
void WriteDicomSeries(const CtImage& ct, const std::string& folder, const DicomSeriesInfo& info);

}  // namespace dg::io
