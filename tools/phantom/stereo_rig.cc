#include "tools/phantom/stereo_rig.h"

#include <cmath>
#include <numbers>

namespace dg::tools::phantom {
namespace {

// Intrinsics of a stereo endoscope's cameras at 640 x 480 (about 65 degrees
// horizontal field of view), scaled to other image sizes; the two cameras
// differ slightly, as real ones do.
io::CameraCalibration Camera(const PhantomSpec& spec, double fx, double fy, double cx, double cy,
                             std::array<double, 5> distortion) {
  const double scale = spec.width / 640.0;
  io::CameraCalibration camera;
  camera.K << fx * scale, 0, cx * scale, 0, fy * scale, cy * scale, 0, 0, 1;
  for (int i = 0; i < 5; ++i) camera.distortion[i] = distortion[i];
  camera.num_distortion = 5;
  camera.width = spec.width;
  camera.height = spec.height;
  return camera;
}

}  // namespace

Eigen::Isometry3d StereoRig::T_R_C() const {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() = calibration.R;
  transform.translation() = calibration.T_m;
  return transform;
}

StereoRig MakeStereoRig(const PhantomSpec& spec) {
  StereoRig rig;
  const double aspect_cy = spec.height / 480.0 * 640.0 / spec.width;  // keep cy central for other aspects
  rig.calibration.left = Camera(spec, 512.0, 510.5, 322.4, 238.9 * aspect_cy, {-0.28, 0.11, 9e-4, -6e-4, -0.02});
  rig.calibration.right = Camera(spec, 508.7, 507.9, 317.2, 242.3 * aspect_cy, {-0.27, 0.10, -7e-4, 5e-4, -0.018});

  // The right camera sits baseline_m along the left camera's x axis, turned 1
  // degree inward (about y) so that both see the same working volume.
  const Eigen::Matrix3d R = Eigen::AngleAxisd(-1.0 * std::numbers::pi / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
  rig.calibration.R = R;
  rig.calibration.T_m = -R * Eigen::Vector3d(spec.baseline_m, 0, 0);

  // Look at the upper middle of the phantom from the front (-y), 50 degrees
  // above the mount plane, with the surface at about the working distance.
  const Eigen::Vector3d target(0, 0, spec.centre_height_m + 0.3 * spec.semi_axes_m.z());
  const double elevation = 50 * std::numbers::pi / 180;
  const double distance = spec.working_distance_m + spec.semi_axes_m.y();
  const Eigen::Vector3d centre = target + distance * Eigen::Vector3d(0, -std::cos(elevation), std::sin(elevation));
  const Eigen::Vector3d z_C = (target - centre).normalized();
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d y_C = -(up - up.dot(z_C) * z_C).normalized();  // image rows go down
  const Eigen::Vector3d x_C = y_C.cross(z_C);
  Eigen::Matrix3d R_C_S;
  R_C_S << x_C.transpose(), y_C.transpose(), z_C.transpose();
  rig.T_C_S.linear() = R_C_S;
  rig.T_C_S.translation() = -R_C_S * centre;
  return rig;
}

}  // namespace dg::tools::phantom
