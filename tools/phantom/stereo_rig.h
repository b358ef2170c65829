#pragma once

#include <Eigen/Geometry>

#include "io/calibration.h"
#include "tools/phantom/phantom_spec.h"

namespace dg::tools::phantom {

// The phantom's stereo endoscope: two cameras with radial and tangential
// distortion (OpenCV's five-coefficient model), a baseline along the left
// camera's x axis with a slight toe-in, looking down at the phantom from the
// front at the spec's working distance. These are the true values the
// calibration and registration are tested against.
struct StereoRig {
  io::StereoCalibration calibration;
  Eigen::Isometry3d T_C_S = Eigen::Isometry3d::Identity();  // scan frame to the left camera frame

  // Left camera frame to the right one: x_R = R x_L + T.
  Eigen::Isometry3d T_R_C() const;
  // Scan frame to the right camera frame.
  Eigen::Isometry3d T_R_S() const { return T_R_C() * T_C_S; }
};

StereoRig MakeStereoRig(const PhantomSpec& spec);

}  // namespace dg::tools::phantom
