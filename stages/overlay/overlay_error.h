#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "io/calibration.h"

namespace dg::stages::overlay {

// The overlay's accuracy against ground truth, per frame (paper Table 1).
// The pipeline's error sink calls these and writes the results to /errors.

// 2D surface overlay error: for surface material points, the distance in the
// left image between where the overlay draws them (their embedded positions
// in the simulated mesh, projected with the lens model: where the overlay's
// vertices land, lens_view.h) and where they truly are; and that distance in
// millimetres at the point's true depth z, e_px z / sqrt(fx fy) (the lens's
// local magnification is ignored: a few percent at the image's edge).
struct SurfaceOverlayError {
  std::vector<int> points;        // the visible points measured, indices into the inputs
  std::vector<double> error_px;
  std::vector<double> error_mm;
};

// drawn_C: the embedded points in the left camera frame; true_uv_px, true_C:
// the truth (pixels with distortion, positions); visible: 1 where the point
// is visible in the left image (others are skipped).
// @throws dg::Error if the inputs' sizes differ.
SurfaceOverlayError MeasureSurfaceOverlayError(const io::CameraCalibration& left, const Eigen::Matrix3Xd& drawn_C,
                                               const Eigen::Matrix2Xd& true_uv_px, const Eigen::Matrix3Xd& true_C,
                                               const std::vector<std::uint8_t>& visible);

// 3D internal error: distances between the embedded internal features and
// their true positions, in millimetres. @throws dg::Error if the sizes differ.
std::vector<double> InternalErrorMm(const Eigen::Matrix3Xd& embedded_C, const Eigen::Matrix3Xd& true_C);

// Median, 95th percentile and maximum of a set of errors (zeros when empty).
struct ErrorSummary {
  int count = 0;
  double median = 0, p95 = 0, max = 0;
};
ErrorSummary Summarize(std::vector<double> values);

}  // namespace dg::stages::overlay
