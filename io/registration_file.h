#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace dg::io {

class H5Writer;

// Reprojection residuals of one camera after registration, over the
// observations the robust fit kept (the others are counted as outliers).
// Millimetres are the pixel error scaled to the fiducial's depth in that
// camera (error_px * z / f), the figure the paper reports (0.47 mm).
struct ReprojectionStats {
  int observations = 0;  // kept
  int outliers = 0;      // left out of the figures below
  double mean_px = 0, max_px = 0, rms_px = 0;
  double mean_mm = 0, max_mm = 0, rms_mm = 0;
};

// A spatiotemporal registration of the 4D scan to the video: what a scene
// can reuse instead of registering again, and what
// the run log keeps under /registration.
struct Registration {
  Eigen::Matrix4d T_C_S = Eigen::Matrix4d::Identity();  // scan frame S to the left camera frame C, metres
  // Video time t maps to scan phase frac((t + phase_shift_s) / period_s).
  double phase_shift_s = 0;
  double period_s = 0;
  double cycles = 0;  // length of the registration window in periods
  ReprojectionStats left, right;
  // Of (rotation vector [rad], translation [m], phase shift [s]), scaled by
  // the residual variance: its square roots are one-sigma uncertainties.
  Eigen::Matrix<double, 7, 7> covariance = Eigen::Matrix<double, 7, 7>::Zero();

  double rotation_sigma_deg() const;     // the largest axis's
  double translation_sigma_mm() const;   // the largest axis's
  double phase_shift_sigma_ms() const;
};

// Writes the registration as YAML (metres, seconds; residuals in px and mm).
// @throws dg::Error when the file cannot be written.
void WriteRegistrationYaml(const std::string& path, const Registration& registration);

// Reads that file back. @throws dg::Error naming file, line and key of a
// missing, unknown or malformed key, or a T_C_S that is not a rigid transform.
Registration ReadRegistrationYaml(const std::string& path);

// Writes the registration under `group` of an HDF5 file (the run log's
// /registration): T_C_S [4,4], phase_shift_s, period_s, cycles, covariance
// [7,7] and {left,right}/{observations,outliers,mean_px,...}.
void WriteRegistrationH5(io::H5Writer* file, const std::string& group, const Registration& registration);

// A user's first-frame fiducial pixels: one "u,v" (or "u v") line per
// fiducial, in the scan's fiducial order, in the first left frame's original
// pixels; lines starting with # are comments.
// @throws dg::Error naming the file and line of a malformed line, or no fiducials.
std::vector<Eigen::Vector2d> ReadFiducialPixels(const std::string& path);

}  // namespace dg::io
