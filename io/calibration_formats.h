#pragma once

#include <optional>
#include <string>

#include <Eigen/Core>

#include "io/calibration.h"
#include "io/calibration_keys.h"

namespace dg::io {

// The layouts of calibration files the reader accepts, told apart by their keys.
enum class CalibrationLayout {
  kDynaguide,              // K1 D1 K2 D2 R T [image_size] [R1 R2 P1 P2 Q]: the whole calibration
  kStereoCalibIntrinsics,  // M1 D1 M2 D2: OpenCV's stereo_calib sample's intrinsics.yml
  kExtrinsics,             // R T [R1 R2 P1 P2 Q]: that sample's extrinsics.yml
  kCameraInfo,             // camera_matrix distortion_coefficients image_width image_height: one camera
};

// The accepted key sets, for the message of a file or a set of files that is none of them.
extern const char* const kAcceptedCalibrations;

// OpenCV's distortion models the project uses: k1 k2 p1 p2 [k3 [k4 k5 k6]].
bool IsSupportedDistortionCount(int count);

std::string LayoutName(CalibrationLayout layout);

// @throws dg::Error naming the file, its keys and the accepted key sets when it is none of the layouts.
CalibrationLayout RecogniseLayout(const CalibrationKeys& file);

// One camera's K and distortion under the given keys; width and height are left 0.
CameraCalibration ReadCamera(const CalibrationKeys& file, const std::string& K_key, const std::string& D_key);

// R (checked to be a rotation), T in the file's unit into T_m, and the
// rectification R1 R2 P1 P2 Q when the file gives it (all or none).
void ReadExtrinsics(const CalibrationKeys& file, StereoCalibration* calibration);

// One camera as a ROS camera_info (or OpenCV's calibration sample's output,
// which has the same keys) gives it.
struct CameraInfo {
  CameraCalibration camera;                             // with the image size
  std::optional<Eigen::Matrix3d> rectification;         // rectification_matrix
  std::optional<Eigen::Matrix<double, 3, 4>> projection;  // projection_matrix
};
CameraInfo ReadCameraInfo(const CalibrationKeys& file);

// R, T (in the files' unit) and the rectification that a stereo pair's two
// camera_info give, by ROS's convention: each camera's rectification_matrix
// turns its frame into the common rectified one, and the right camera's
// projection_matrix P = K' [I | t] holds in t the right camera's position
// relative to the left one in that rectified frame (the left camera's t is
// 0; Tx = -fx' B for a horizontal pair of baseline B). Then X_R = R X_L + T
// with R = R_right^T R_left and T = R_right^T t.
// @returns false, saying why in *why_not, when the pair gives no
// baseline (no rectification or projection matrices, or t = 0 as two
// monocular calibrations have): then only an extrinsics file can give R and T.
// @throws dg::Error for a rectification_matrix that is not a rotation, or a
// left camera with a nonzero t (the files given in the wrong order).
bool ExtrinsicsFromCameraInfos(const CameraInfo& left, const CameraInfo& right, const CalibrationKeys& left_file,
                               StereoCalibration* calibration, std::string* why_not);

}  // namespace dg::io
