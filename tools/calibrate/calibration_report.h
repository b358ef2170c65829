#pragma once

#include <string>

#include "tools/calibrate/stereo_calibration.h"

namespace dg::tools::calibrate {

// The figures a user checks after calibrating, as lines of text: views used
// and rejected (naming them), per-camera and stereo RMS, epipolar error,
// focal lengths, principal points and baseline.
std::string DescribeReport(const StereoCalibrationReport& report);

// The same as JSON: rms_left, rms_right, rms_stereo, epipolar_error_px (all
// pixels), views_used, views_rejected, baseline_m, and the rejected views' reasons.
// @throws dg::Error when the file cannot be written.
void WriteReportJson(const std::string& path, const StereoCalibrationReport& report);

}  // namespace dg::tools::calibrate
