#include "stages/overlay/overlay_error.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "sim/error.h"
#include "stages/camera_model.h"

namespace dg::stages::overlay {

SurfaceOverlayError MeasureSurfaceOverlayError(const io::CameraCalibration& left, const Eigen::Matrix3Xd& drawn_C,
                                               const Eigen::Matrix2Xd& true_uv_px, const Eigen::Matrix3Xd& true_C,
                                               const std::vector<std::uint8_t>& visible) {
  const Eigen::Index count = drawn_C.cols();
  if (true_uv_px.cols() != count || true_C.cols() != count || static_cast<Eigen::Index>(visible.size()) != count)
    throw Error("surface points: " + std::to_string(count) + " drawn, " + std::to_string(true_uv_px.cols()) +
                    " true pixels, " + std::to_string(true_C.cols()) + " true positions, " +
                    std::to_string(visible.size()) + " visibility flags",
                "MeasureSurfaceOverlayError", "pass the same surface points in the same order");
  const double pixels_per_unit_depth = std::sqrt(left.fx() * left.fy());
  SurfaceOverlayError result;
  for (Eigen::Index p = 0; p < count; ++p) {
    if (!visible[p] || !(drawn_C(2, p) > 0)) continue;
    const double error_px = (Project(left, drawn_C.col(p)) - true_uv_px.col(p)).norm();
    result.points.push_back(static_cast<int>(p));
    result.error_px.push_back(error_px);
    result.error_mm.push_back(error_px * true_C(2, p) / pixels_per_unit_depth * 1e3);
  }
  return result;
}

std::vector<double> InternalErrorMm(const Eigen::Matrix3Xd& embedded_C, const Eigen::Matrix3Xd& true_C) {
  if (embedded_C.cols() != true_C.cols())
    throw Error("internal points: " + std::to_string(embedded_C.cols()) + " embedded, " +
                    std::to_string(true_C.cols()) + " true",
                "InternalErrorMm", "pass the same internal points in the same order");
  std::vector<double> errors(embedded_C.cols());
  for (Eigen::Index p = 0; p < embedded_C.cols(); ++p) errors[p] = (embedded_C.col(p) - true_C.col(p)).norm() * 1e3;
  return errors;
}

ErrorSummary Summarize(std::vector<double> values) {
  ErrorSummary summary;
  summary.count = static_cast<int>(values.size());
  if (values.empty()) return summary;
  std::sort(values.begin(), values.end());
  summary.median = values[values.size() / 2];
  summary.p95 = values[std::min(values.size() - 1, values.size() * 95 / 100)];
  summary.max = values.back();
  return summary;
}

}  // namespace dg::stages::overlay
