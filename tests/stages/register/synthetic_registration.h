#pragma once
// A synthetic registration problem with an exact answer: an endoscope-like
// stereo pair, fiducials beating on closed curves, a known pose and shift,
// and their exact sightings.
#include <cmath>
#include <vector>

#include <Eigen/Geometry>

#include "io/calibration.h"
#include "stages/camera_model.h"
#include "stages/register/fiducial_motion.h"
#include "stages/register/fiducial_tracks.h"

namespace dg::stages {

inline constexpr double kPeriod_s = 2.0 / 3.0;  // 90 bpm
inline constexpr double kFps = 30;

// An endoscope-like pair with OpenCV distortion: 5 mm baseline, slightly toed in.
inline io::StereoCalibration SyntheticCalibration() {
  io::StereoCalibration c;
  c.left.K << 800, 0, 322, 0, 805, 238, 0, 0, 1;
  c.left.distortion = {-0.21, 0.06, 8e-4, -5e-4, 0.01, 0, 0, 0};
  c.right.K << 795, 0, 318, 0, 798, 243, 0, 0, 1;
  c.right.distortion = {-0.19, 0.04, -6e-4, 3e-4, 0, 0, 0, 0};
  c.left.width = c.right.width = 640;
  c.left.height = c.right.height = 480;
  c.R = Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitY()).toRotationMatrix();
  c.T_m = Eigen::Vector3d(-0.005, 0.0001, 0.0002);
  return c;
}

// Five fiducials beating on closed 3-D curves of a few millimetres, sampled at
// P scan phases.
inline FiducialMotion SyntheticMotion(int fiducials, int phases) {
  FiducialMotion motion;
  for (int k = 0; k < phases; ++k) {
    const double phi = double(k) / phases, w = 2 * M_PI * phi;
    Eigen::Matrix3Xd x(3, fiducials);
    for (int i = 0; i < fiducials; ++i) {
      const double a = 2 * M_PI * i / fiducials;
      const Eigen::Vector3d centre(0.015 * std::cos(a), 0.012 * std::sin(a), 0.03 + 0.004 * std::cos(2 * a));
      const Eigen::Vector3d beat(0.002 * std::sin(w + a), 0.0015 * (std::cos(w) - 1), 0.001 * std::sin(2 * w));
      x.col(i) = centre + beat;
    }
    motion.phases.push_back(phi);
    motion.positions_S_m.push_back(x);
  }
  return motion;
}

// The camera 6 cm from the scan's centre, looking down at it obliquely.
inline Eigen::Isometry3d TruePose() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(2.3, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.001, -0.002, 0.06) - T.linear() * Eigen::Vector3d(0, 0, 0.03);
  return T;
}

// Exact sightings of the interpolated motion at shift lambda over `cycles` periods.
inline FiducialTracks SyntheticTracks(const FiducialMotion& motion, const io::StereoCalibration& calibration,
                               const Eigen::Isometry3d& T_C_S, double shift_s, double cycles) {
  FiducialTracks tracks;
  const int frames = static_cast<int>(std::ceil(cycles * kPeriod_s * kFps - 1e-9));
  for (int j = 0; j < frames; ++j) {
    const double t = j / kFps;
    std::vector<FiducialSighting> frame;
    for (int i = 0; i < motion.num_fiducials(); ++i) {
      Eigen::Vector3d x_S;
      FiducialAtPhase(motion, i, (t + shift_s) / kPeriod_s, x_S.data());
      const Eigen::Vector3d x_C = T_C_S * x_S;
      frame.push_back({true, true, Project(calibration.left, x_C), Project(calibration.right, calibration.R * x_C + calibration.T_m)});
    }
    tracks.t_s.push_back(t);
    tracks.frames.push_back(frame);
  }
  return tracks;
}

inline double PhaseError_s(double a, double b) {
  const double d = a - b;
  return d - kPeriod_s * std::round(d / kPeriod_s);
}

}  // namespace dg::stages
