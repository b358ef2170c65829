#pragma once

#include <optional>
#include <string>

#include "stages/register/registration.h"

namespace dg::tools {

struct RegisterRunOptions {
  std::string scene;          // scene.yaml with preoperative data, video and calibration
  double cycles = 0;          // the window, in scan periods; 0: the scene's registration.cycles
  std::string fiducials_uv;   // first-frame left pixels of the fiducials (ReadFiducialPixels); else the scene's, else its truth's
  bool ct_beads = false;      // the fiducials' scan positions from the CT's beads instead of the scan file
  stages::RegistrationOptions solver;
  bool progress = false;      // on stderr
};

// The registration against the scene's ground truth, when it has one.
struct RegistrationError {
  double rotation_deg = 0, translation_mm = 0, phase_shift_ms = 0;
};

struct RegisterRunSummary {
  stages::RegistrationResult result;
  int frames = 0;        // in the window
  int fiducials = 0;
  std::string fiducials_from;  // where the scan positions came from
  std::string starts_from;     // where the first-frame pixels came from
  double track_ms = 0, solve_ms = 0;
  std::optional<RegistrationError> error;
};

// `dynaguide register`: the fiducials' scan positions (the scan file's
// /phases/fiducials_S_m, or beads found in the CT volumes), their video tracks
// over the first `cycles` periods (FiducialTracker from the first-frame pixels
// the user gives, or the truth's when the scene has one), then the registration.
// @throws dg::Error for a scene without preoperative data, first-frame pixels
//   neither given nor in a truth file, counts that do not match, or the
//   registration's own bad-input errors.
RegisterRunSummary RunRegister(const RegisterRunOptions& options);

// The result for a terminal: pose, shift, residuals, uncertainty and any truth error.
std::string RegisterReport(const RegisterRunSummary& summary);

// The JSON users script against: T_C_S (4x4 row-major, metres),
// phase_shift_s, residual_px_left/right, residual_mm_left/right (means),
// cycles, and the rest of the statistics. @throws dg::Error if it cannot be written.
void WriteRegisterJson(const std::string& path, const RegisterRunSummary& summary);

// The angle of the rotation between two rigid transforms' rotations, in degrees.
double RotationAngleDeg(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b);

// Compares a registration with a phantom's truth; the phase difference is
// taken modulo the period, into (-period/2, period/2].
RegistrationError CompareWithTruth(const io::Registration& registration, const Eigen::Matrix4d& T_C_S_truth,
                                   double phase_shift_truth_s);

}  // namespace dg::tools
