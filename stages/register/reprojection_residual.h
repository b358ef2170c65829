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

// A point in the left camera's frame C projected into an eye, in pixels;
// false behind the eye. Written for Ceres' Jet as well as double.
template <typename T>
bool ProjectInEye(const EyeModel& eye, const T* xyz_C, T* uv_px) {
  T xyz_E[3];
  for (int r = 0; r < 3; ++r) {
    T sum = T(eye.t_E_C_m[r]);
    for (int c = 0; c < 3; ++c) sum += T(eye.R_E_C(r, c)) * xyz_C[c];
    xyz_E[r] = sum;
  }
  if (!(xyz_E[2] > T(0))) return false;
  const T intrinsics[4] = {T(eye.intrinsics[0]), T(eye.intrinsics[1]), T(eye.intrinsics[2]), T(eye.intrinsics[3])};
  T distortion[8];
  for (int k = 0; k < 8; ++k) distortion[k] = T(eye.distortion[k]);
  ProjectPoint(intrinsics, distortion, xyz_E, uv_px);
  return true;
}

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
    T xyz_S[3], xyz_C[3], uv[2];
    FiducialAtPhase(*motion, fiducial, (T(t_s) + shift_s[0]) / T(period_s), xyz_S);
    ceres::AngleAxisRotatePoint(rotation_C_S, xyz_S, xyz_C);
    for (int c = 0; c < 3; ++c) xyz_C[c] += translation_C_S_m[c];
    if (!ProjectInEye(*eye, xyz_C, uv)) return false;  // behind the eye: no projection (Ceres rejects the step)
    residual[0] = uv[0] - T(observed_px.x());
    residual[1] = uv[1] - T(observed_px.y());
    return true;
  }
};

// The residual of a fixed point of the scan in one eye, for a pose alone:
// p_E(R_E_C (T_C_S x_S) + t_E_C) - observed, parameters as above without the shift.
struct StaticPointResidual {
  const EyeModel* eye;
  Eigen::Vector3d x_S_m;
  Eigen::Vector2d observed_px;

  template <typename T>
  bool operator()(const T* rotation_C_S, const T* translation_C_S_m, T* residual) const {
    const T xyz_S[3] = {T(x_S_m.x()), T(x_S_m.y()), T(x_S_m.z())};
    T xyz_C[3], uv[2];
    ceres::AngleAxisRotatePoint(rotation_C_S, xyz_S, xyz_C);
    for (int c = 0; c < 3; ++c) xyz_C[c] += translation_C_S_m[c];
    if (!ProjectInEye(*eye, xyz_C, uv)) return false;
    residual[0] = uv[0] - T(observed_px.x());
    residual[1] = uv[1] - T(observed_px.y());
    return true;
  }
};

}  // namespace dg::stages
