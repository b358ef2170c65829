#pragma once

#include <string>
#include <utility>
#include <vector>

namespace dg::io {

// Where a stereo calibration is read from: one file in dynaguide's layout,
// or the files that together hold one (docs/formats/calibration.md lists
// them): OpenCV's stereo_calib sample's intrinsics.yml and extrinsics.yml, or
// the left and the right camera's camera_info, alone or followed by an
// extrinsics file.
struct CalibrationSource {
  CalibrationSource() = default;
  // A path converts: most calibrations are one file.
  CalibrationSource(std::string path) : files{std::move(path)} {}  // NOLINT(google-explicit-constructor)
  CalibrationSource(const char* path) : files{path} {}             // NOLINT(google-explicit-constructor)

  std::vector<std::string> files;
  // Metres per unit of the files' translations (T, and the last columns of
  // P1 and P2): OpenCV gives them in the unit the chessboard's square size
  // was given in, which the files do not record.
  double metres_per_unit = 1.0;

  bool empty() const { return files.empty(); }
  std::string Describe() const;  // the files joined by " + ", for messages
};

// T's unit as a scene (calibration_units) or a command names it: a length
// unit (m, cm, mm, um), or metres per unit as a positive number (the square's
// side in metres for a calibration made with square size 1, as OpenCV's
// stereo_calib sample makes it by default).
// @throws dg::Error naming `where` and the accepted forms.
double CalibrationMetresPerUnit(const std::string& text, const std::string& where);

}  // namespace dg::io
