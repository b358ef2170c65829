#pragma once

#include <array>

#include <Eigen/Core>
#include <ceres/rotation.h>

#include "io/calibration.h"
#include "stages/camera_model.h"
#include "stages/register/fiducial_motion.h"

namespace dg::stages {

// One eye of the calibrated pair, as the residual needs it: its pose relative
// to the left camera (identity for the left eye; the calibration's R, T for
// the right) and its full distortion model.
struct EyeModel {
  std::array<double, 4> intrinsics{};  // fx fy cx cy
  std::array<double, 8> distortion{};
  Eigen::Matrix3d R_E_C = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_E_C_m = Eigen::Vector3d::Zero();

  static EyeModel Left(const io::StereoCalibration& calibration);
  static EyeModel Right(const io::StereoCalibration& calibration);
};

// The residual of one fiducial sighting in one eye (paper eq. 1, one term):
//   p_E(R_E_C (T_C_S s_i((t_j + lambda) / period)) + t_E_C) - t_ij,
// in pixels, for Ceres' automatic differentiation. Parameters: the rotation
// of T_C_S as an angle-axis vector [3], its translation in metres [3] and the
// phase shift lambda in seconds [1]. The motion and eye are borrowed and must
// outlive the residual.
struct ReprojectionResidual {
  const FiducialMotion* motion;
  const EyeModel* eye;
  int fiducial;
  double t_s;
  double period_s;
  Eigen::Vector2d observed_px;

  template <typename T>
  bool operator()(const T* rotation_C_S, const T* translation_C_S_m, const T* shift_s, T* residual) const {
    T xyz_S[3], xyz_C[3], xyz_E[3];
    FiducialAtPhase(*motion, fiducial, (T(t_s) + shift_s[0]) / T(period_s), xyz_S);
    ceres::AngleAxisRotatePoint(rotation_C_S, xyz_S, xyz_C);
    for (int r = 0; r < 3; ++r) {
      T sum = T(eye->t_E_C_m[r]);
      for (int c = 0; c < 3; ++c) sum += T(eye->R_E_C(r, c)) * (xyz_C[c] + translation_C_S_m[c]);
      xyz_E[r] = sum;
    }
    if (!(xyz_E[2] > T(0))) return false;  // behind the eye: no projection (Ceres rejects the step)
    const T intrinsics[4] = {T(eye->intrinsics[0]), T(eye->intrinsics[1]), T(eye->intrinsics[2]), T(eye->intrinsics[3])};
    T distortion[8];
    for (int k = 0; k < 8; ++k) distortion[k] = T(eye->distortion[k]);
    T uv[2];
    ProjectPoint(intrinsics, distortion, xyz_E, uv);
    residual[0] = uv[0] - T(observed_px.x());
    residual[1] = uv[1] - T(observed_px.y());
    return true;
  }
};

}  // namespace dg::stages
