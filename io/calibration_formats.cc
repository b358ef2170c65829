#include "io/calibration_formats.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include <Eigen/LU>
#include <Eigen/SVD>

#include "sim/error.h"
#include "sim/log.h"

namespace dg::io {

const char* const kAcceptedCalibrations =
    "give one file in dynaguide's layout (K1 D1 K2 D2 R T, and image_size [w, h]), as dynaguide calibrate writes "
    "it; or OpenCV's stereo_calib pair: intrinsics.yml (M1 D1 M2 D2) and extrinsics.yml (R T, with R1 R2 P1 P2 Q "
    "or without); or a ROS camera_info per camera, left then right (camera_matrix, distortion_coefficients, "
    "image_width, image_height, and rectification_matrix and projection_matrix, from which a stereo pair's R and T "
    "follow), followed by extrinsics.yml when the two give no baseline";

bool IsSupportedDistortionCount(int count) { return count == 4 || count == 5 || count == 8; }

namespace {

void ReadDistortion(const CalibrationKeys& file, const std::string& key, CameraCalibration* camera) {
  const Eigen::VectorXd coefficients = file.Vector(key);
  const int count = static_cast<int>(coefficients.size());
  if (!IsSupportedDistortionCount(count)) {
    file.Fail(key, "expected 4, 5 or 8 distortion coefficients in a row, found " + std::to_string(count),
              "calibrate without the thin-prism and tilt terms (no CALIB_THIN_PRISM_MODEL or CALIB_TILTED_MODEL)");
  }
  camera->num_distortion = count;
  camera->distortion.fill(0.0);
  for (int i = 0; i < count; ++i) camera->distortion[i] = coefficients(i);
}

// The rotation a file's key gives. Files written by hand or converted from
// other tools round R to a few digits (the Hamlyn data's to 6: |R^T R - I| =
// 1e-6); up to kRoundedRotation that is rounding, and the nearest rotation
// (the SVD's U V^T) replaces it, with a note. Beyond it, the matrix is not a
// rotation: a wrong key, a transposed or scaled matrix.
constexpr double kRoundedRotation = 1e-4;
Eigen::Matrix3d Rotation(const CalibrationKeys& file, const std::string& key) {
  const Eigen::Matrix3d R = file.Matrix(key, 3, 3);
  const double orthogonality = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  if (!(orthogonality <= kRoundedRotation) || R.determinant() < 0) {
    char what[160];
    std::snprintf(what, sizeof what, "not a rotation (|R^T R - I| = %.3g, det = %.6g; up to %.0e is taken as rounding)",
                  orthogonality, R.determinant(), kRoundedRotation);
    file.Fail(key, what);
  }
  if (orthogonality <= 1e-12) return R;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d nearest = svd.matrixU() * svd.matrixV().transpose();
  Logger("io").info("{}: {} is a rotation to {:.2g} (|R^T R - I|), as rounded digits give: the nearest rotation is used, "
                    "{:.2g} from it",
                    file.path(), key, orthogonality, (nearest - R).norm());
  return nearest;
}

// Q as cv::stereoRectify builds it from the rectified pair: reprojects
// (u, v, disparity, 1) of the left rectified image to homogeneous 3D.
Eigen::Matrix4d ReprojectionMatrix(const Eigen::Matrix<double, 3, 4>& P1, const Eigen::Matrix<double, 3, 4>& P2,
                                   const Eigen::Vector3d& t) {
  const int axis = std::abs(t.x()) >= std::abs(t.y()) ? 0 : 1;  // horizontal or vertical pair
  Eigen::Matrix4d Q = Eigen::Matrix4d::Zero();
  Q(0, 0) = Q(1, 1) = 1;
  Q(0, 3) = -P1(0, 2);
  Q(1, 3) = -P1(1, 2);
  Q(2, 3) = P1(axis, axis);
  Q(3, 2) = -1.0 / t(axis);
  Q(3, 3) = (P1(axis, 2) - P2(axis, 2)) / t(axis);
  return Q;
}

}  // namespace

std::string LayoutName(CalibrationLayout layout) {
  switch (layout) {
    case CalibrationLayout::kDynaguide: return "dynaguide's layout (K1 D1 K2 D2 R T)";
    case CalibrationLayout::kStereoCalibIntrinsics: return "stereo_calib intrinsics (M1 D1 M2 D2)";
    case CalibrationLayout::kExtrinsics: return "extrinsics (R T)";
    case CalibrationLayout::kCameraInfo: return "camera_info (camera_matrix)";
  }
  return "";
}

CalibrationLayout RecogniseLayout(const CalibrationKeys& file) {
  if (file.Has("K1") || file.Has("K2")) return CalibrationLayout::kDynaguide;
  if (file.Has("M1") || file.Has("M2")) return CalibrationLayout::kStereoCalibIntrinsics;
  if (file.Has("camera_matrix")) return CalibrationLayout::kCameraInfo;
  if (file.Has("T") || file.Has("R")) return CalibrationLayout::kExtrinsics;
  throw Error("not a camera calibration: none of the accepted key sets (the file's keys: " + file.KeyList() + ")",
              file.path(), kAcceptedCalibrations);
}

CameraCalibration ReadCamera(const CalibrationKeys& file, const std::string& K_key, const std::string& D_key) {
  CameraCalibration camera;
  camera.K = file.Matrix(K_key, 3, 3);
  if (!(camera.K(0, 0) > 0) || !(camera.K(1, 1) > 0)) {
    file.Fail(K_key, "has no positive focal length: the camera is not calibrated");
  }
  ReadDistortion(file, D_key, &camera);
  return camera;
}

void ReadExtrinsics(const CalibrationKeys& file, StereoCalibration* calibration) {
  calibration->R = Rotation(file, "R");
  calibration->T_m = file.Matrix("T", 3, 1);
  // E and F follow from the rest and are recomputed, not read.
  const std::array<const char*, 5> rectification_keys = {"R1", "R2", "P1", "P2", "Q"};
  const bool any = std::any_of(rectification_keys.begin(), rectification_keys.end(),
                               [&](const char* key) { return file.Has(key); });
  calibration->rectification.reset();
  if (!any) return;
  for (const char* key : rectification_keys) {
    if (!file.Has(key)) {
      file.Fail(key, "missing while other rectification keys are given",
                "give all of R1 R2 P1 P2 Q (as stereoRectify returns them), or none");
    }
  }
  calibration->rectification =
      StereoCalibration::Rectification{file.Matrix("R1", 3, 3), file.Matrix("R2", 3, 3), file.Matrix("P1", 3, 4),
                                        file.Matrix("P2", 3, 4), file.Matrix("Q", 4, 4)};
}

CameraInfo ReadCameraInfo(const CalibrationKeys& file) {
  CameraInfo info;
  info.camera = ReadCamera(file, "camera_matrix", "distortion_coefficients");
  if (file.Has("distortion_model")) {
    // ROS's names for OpenCV's models; "equidistant" is the fisheye model, whose
    // four coefficients would be misread as k1 k2 p1 p2.
    const std::string model = file.Text("distortion_model");
    const int count = info.camera.num_distortion;
    const bool pinhole = (model == "plumb_bob" && (count == 4 || count == 5)) ||
                         (model == "rational_polynomial" && count == 8);
    if (!pinhole) {
      file.Fail("distortion_model",
                "'" + model + "' with " + std::to_string(count) +
                    " coefficients is not OpenCV's pinhole model (plumb_bob: 5, rational_polynomial: 8)",
                "calibrate the cameras with the pinhole model (plumb_bob or rational_polynomial)");
    }
  }
  info.camera.width = file.PositiveInteger("image_width");
  info.camera.height = file.PositiveInteger("image_height");
  if (file.Has("rectification_matrix")) {
    info.rectification = Rotation(file, "rectification_matrix");
  }
  if (file.Has("projection_matrix")) info.projection = file.Matrix("projection_matrix", 3, 4);
  return info;
}

bool ExtrinsicsFromCameraInfos(const CameraInfo& left, const CameraInfo& right, const CalibrationKeys& left_file,
                               StereoCalibration* calibration, std::string* why_not) {
  if (!left.rectification || !right.rectification || !left.projection || !right.projection) {
    *why_not = "they lack rectification_matrix or projection_matrix, which a stereo pair's camera_info has";
    return false;
  }
  // P = K' [I | t]: t from the last column through the rectified intrinsics.
  const auto translation = [](const Eigen::Matrix<double, 3, 4>& P) -> Eigen::Vector3d {
    return P.leftCols<3>().inverse() * P.col(3);
  };
  const Eigen::Vector3d t_left = translation(*left.projection), t = translation(*right.projection);
  if (!t_left.allFinite() || !t.allFinite()) {
    *why_not = "a projection_matrix has no invertible left 3x3 part";
    return false;
  }
  if (t_left.norm() > 0) {
    left_file.Fail("projection_matrix",
                   "has a nonzero Tx or Ty, which ROS gives the second (right) camera only",
                   "give the left camera's camera_info first, then the right one's");
  }
  if (!(t.norm() > 0)) {
    *why_not = "the right camera's projection_matrix has Tx = Ty = 0, as two monocular calibrations have";
    return false;
  }
  const Eigen::Matrix3d &R_left = *left.rectification, &R_right = *right.rectification;
  calibration->R = R_right.transpose() * R_left;
  calibration->T_m = R_right.transpose() * t;
  calibration->rectification = StereoCalibration::Rectification{
      R_left, R_right, *left.projection, *right.projection,
      ReprojectionMatrix(*left.projection, *right.projection, t)};
  return true;
}

}  // namespace dg::io
