#include "stages/rectify.h"

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <tbb/parallel_invoke.h>

#include "sim/error.h"
#include "stages/camera_model.h"

namespace dg::stages {
namespace {

cv::Mat ToCv(const Eigen::MatrixXd& matrix) {
  cv::Mat mat;
  cv::eigen2cv(matrix, mat);
  return mat;
}

cv::Mat Distortion(const io::CameraCalibration& camera) {
  return ToCv(Eigen::Map<const Eigen::RowVectorXd>(camera.distortion.data(), camera.num_distortion));
}

std::string SizeText(const cv::Size& size) {
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

}  // namespace

io::StereoCalibration::Rectification ComputeRectification(const io::StereoCalibration& calibration, double alpha) {
  const io::CameraCalibration &left = calibration.left, &right = calibration.right;
  const cv::Size size(left.width, left.height);
  if (size != cv::Size(right.width, right.height) || size.area() <= 0) {
    throw Error("the calibration's image sizes differ or are empty (" + SizeText(size) + " and " +
                    SizeText(cv::Size(right.width, right.height)) + ")",
                "stereo calibration", "calibrate the pair again with dynaguide calibrate");
  }
  cv::Mat R1, R2, P1, P2, Q;
  cv::stereoRectify(ToCv(left.K), Distortion(left), ToCv(right.K), Distortion(right), size, ToCv(calibration.R),
                    ToCv(calibration.T_m), R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, alpha);
  io::StereoCalibration::Rectification rectification;
  cv::cv2eigen(R1, rectification.R1);
  cv::cv2eigen(R2, rectification.R2);
  cv::cv2eigen(P1, rectification.P1);
  cv::cv2eigen(P2, rectification.P2);
  cv::cv2eigen(Q, rectification.Q);
  return rectification;
}

std::string RectifyStage::Options::Validate() const {
  if (!(alpha >= 0 && alpha <= 1)) return "alpha must lie in [0, 1]";
  if (interpolation != cv::INTER_NEAREST && interpolation != cv::INTER_LINEAR &&
      interpolation != cv::INTER_CUBIC && interpolation != cv::INTER_LANCZOS4) {
    return "interpolation must be nearest, linear, cubic or Lanczos";
  }
  return "";
}

RectifyStage::RectifyStage(const Options& options, const io::StereoCalibration& calibration)
    : options_(options), calibration_(calibration) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw Error(problem, "rectification options", "use alpha in [0, 1] and one of OpenCV's interpolations");
  }
  rectification_ = ComputeRectification(calibration, options.alpha);
  const cv::Size size(calibration.left.width, calibration.left.height);
  const cv::Mat P1 = ToCv(rectification_.P1), P2 = ToCv(rectification_.P2);
  // Fixed-point maps: remap quantises to 1/32 px with float maps too, and these are faster.
  cv::initUndistortRectifyMap(ToCv(calibration.left.K), Distortion(calibration.left), ToCv(rectification_.R1), P1,
                              size, CV_16SC2, map1_left_, map2_left_);
  cv::initUndistortRectifyMap(ToCv(calibration.right.K), Distortion(calibration.right), ToCv(rectification_.R2), P2,
                              size, CV_16SC2, map1_right_, map2_right_);
  camera_.R_R_C = rectification_.R1;
  R_right_ = rectification_.R2;
  camera_.P_left = rectification_.P1;
  camera_.P_right = rectification_.P2;
  camera_.f_px = camera_.P_left(0, 0);
  camera_.cx_px = camera_.P_left(0, 2);
  camera_.cy_px = camera_.P_left(1, 2);
  camera_.baseline_m = -camera_.P_right(0, 3) / camera_.f_px;
  camera_.size = size;
}

RectifiedPair RectifyStage::Process(const StereoFrame& frame) const {
  RectifiedPair pair;
  Process(frame, &pair);
  return pair;
}

void RectifyStage::Process(const StereoFrame& frame, RectifiedPair* into) const {
  for (const cv::Mat* image : {&frame.left, &frame.right}) {
    if (image->size() != camera_.size) {
      throw Error("frame " + std::to_string(frame.index) + " is " + SizeText(image->size()) +
                      " but the calibration is for " + SizeText(camera_.size),
                  "rectify, frame " + std::to_string(frame.index),
                  "use the calibration of the camera and resolution that recorded the video");
    }
  }
  into->index = frame.index;
  into->t_s = frame.t_s;
  tbb::parallel_invoke(
      [&] { cv::remap(frame.left, into->left, map1_left_, map2_left_, options_.interpolation); },
      [&] { cv::remap(frame.right, into->right, map1_right_, map2_right_, options_.interpolation); });
}

std::optional<Eigen::Vector2d> RectifyStage::RectifyPixel(Eye eye, const Eigen::Vector2d& uv_distorted) const {
  const bool left = eye == Eye::kLeft;
  Eigen::Vector2d normalized;
  if (!UndistortPixel(left ? calibration_.left : calibration_.right, uv_distorted, &normalized)) return std::nullopt;
  const Eigen::Matrix<double, 3, 4>& P = left ? camera_.P_left : camera_.P_right;
  const Eigen::Vector3d x = P.leftCols<3>() * ((left ? camera_.R_R_C : R_right_) * normalized.homogeneous());
  return Eigen::Vector2d(x.x() / x.z(), x.y() / x.z());
}

}  // namespace dg::stages
