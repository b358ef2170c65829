#include "stages/register/reprojection_residual.h"

namespace dg::stages {
namespace {

EyeModel FromCamera(const io::CameraCalibration& camera) {
  EyeModel eye;
  eye.intrinsics = {camera.fx(), camera.fy(), camera.cx(), camera.cy()};
  eye.distortion = camera.distortion;
  return eye;
}

}  // namespace

EyeModel EyeModel::Left(const io::StereoCalibration& calibration) { return FromCamera(calibration.left); }

EyeModel EyeModel::Right(const io::StereoCalibration& calibration) {
  EyeModel eye = FromCamera(calibration.right);
  eye.R_E_C = calibration.R;
  eye.t_E_C_m = calibration.T_m;
  return eye;
}

}  // namespace dg::stages
