#include "tools/calibrate/stereo_calibration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include "sim/error.h"
#include "stages/rectify.h"

namespace dg::tools::calibrate {
namespace {

using Corners = std::vector<cv::Point2f>;

// The board's inner corners in one view, both eyes, or the reason there are none.
struct DetectedView {
  Corners left, right;
  cv::Size size_left, size_right;
  std::string problem;  // empty when the board was found in both images
};

cv::Mat ReadGrey(const std::string& path) {
  const cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (image.empty()) {
    throw Error("cannot read calibration image", path, "check that the file exists and is an image");
  }
  return image;
}

// Corners refined to sub-pixel with a window of about a third of a square, so
// that it never reaches across to the next corner on a small board image.
std::optional<Corners> FindCorners(const cv::Mat& grey, const cv::Size& board) {
  Corners corners;
  const int flags = cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE;
  if (!cv::findChessboardCorners(grey, board, corners, flags)) return std::nullopt;
  const double square_px = cv::norm(corners[1] - corners[0]);
  const int half_window = std::clamp(static_cast<int>(square_px / 3), 2, 11);
  cv::cornerSubPix(grey, corners, cv::Size(half_window, half_window), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-4));
  return corners;
}

DetectedView Detect(const ViewPair& view, const cv::Size& board) {
  const cv::Mat left = ReadGrey(view.left_path), right = ReadGrey(view.right_path);
  DetectedView detected{{}, {}, left.size(), right.size(), ""};
  const std::optional<Corners> left_corners = FindCorners(left, board);
  const std::optional<Corners> right_corners = FindCorners(right, board);
  if (!left_corners) detected.problem += " left";
  if (!right_corners) detected.problem += " right";
  if (!detected.problem.empty()) {
    detected.problem = "board not found in" + detected.problem;
    return detected;
  }
  detected.left = *left_corners;
  detected.right = *right_corners;
  return detected;
}

std::string SizeText(const cv::Size& size) {
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

int CalibrationFlags(DistortionModel model) {
  switch (model) {
    case DistortionModel::kK4:
      return cv::CALIB_FIX_K3;
    case DistortionModel::kK5:
      return 0;
    case DistortionModel::kK8:
      return cv::CALIB_RATIONAL_MODEL;
  }
  DG_CHECK(false);
}

int CoefficientCount(DistortionModel model) {
  switch (model) {
    case DistortionModel::kK4:
      return 4;
    case DistortionModel::kK5:
      return 5;
    case DistortionModel::kK8:
      return 8;
  }
  DG_CHECK(false);
}

io::CameraCalibration ToCamera(const cv::Mat& K, const cv::Mat& D, const cv::Size& size,
                               DistortionModel model) {
  io::CameraCalibration camera;
  cv::cv2eigen(K, camera.K);
  camera.num_distortion = CoefficientCount(model);
  for (int i = 0; i < camera.num_distortion; ++i) camera.distortion[i] = D.at<double>(i);
  camera.width = size.width;
  camera.height = size.height;
  return camera;
}

// Mean |v_left - v_right| of corresponding corners in rectified pixels.
// undistortPoints is asked to iterate to convergence: its default five steps
// leave errors of tenths of a pixel at the corners of a distorting lens.
double MeanRectifiedRowError(const cv::Mat& K1, const cv::Mat& D1, const cv::Mat& R1, const cv::Mat& P1,
                             const cv::Mat& K2, const cv::Mat& D2, const cv::Mat& R2, const cv::Mat& P2,
                             const std::vector<Corners>& left, const std::vector<Corners>& right) {
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-10);
  double sum = 0;
  size_t count = 0;
  for (size_t v = 0; v < left.size(); ++v) {
    Corners rectified_left, rectified_right;
    cv::undistortPoints(left[v], rectified_left, K1, D1, R1, P1, criteria);
    cv::undistortPoints(right[v], rectified_right, K2, D2, R2, P2, criteria);
    for (size_t i = 0; i < rectified_left.size(); ++i) {
      sum += std::abs(rectified_left[i].y - rectified_right[i].y);
      ++count;
    }
  }
  return sum / count;
}

// |reprojected - detected| of each corner of one view, through the pose and
// intrinsics its camera's calibration found.
std::vector<double> CornerErrors(const std::vector<cv::Point3f>& board, const Corners& detected, const cv::Mat& rvec,
                                 const cv::Mat& tvec, const cv::Mat& K, const cv::Mat& D) {
  std::vector<cv::Point2f> projected;
  cv::projectPoints(board, rvec, tvec, K, D, projected);
  std::vector<double> errors(projected.size());
  for (size_t c = 0; c < projected.size(); ++c) errors[c] = cv::norm(projected[c] - detected[c]);
  return errors;
}

// How far apart the two baselines may be before the calibration is warned of.
constexpr double kBaselineAgreement = 0.05;

// |T| from stereoCalibrate with the intrinsics as a guess it may change: the
// one-step calibration OpenCV's samples do.
double FreeIntrinsicsBaseline(const std::vector<std::vector<cv::Point3f>>& object_points,
                              const std::vector<Corners>& left, const std::vector<Corners>& right, cv::Mat K1,
                              cv::Mat D1, cv::Mat K2, cv::Mat D2, const cv::Size& size, int flags,
                              const cv::TermCriteria& criteria) {
  K1 = K1.clone(), D1 = D1.clone(), K2 = K2.clone(), D2 = D2.clone();
  cv::Mat R, T, E, F;
  cv::stereoCalibrate(object_points, left, right, K1, D1, K2, D2, size, R, T, E, F,
                      flags | cv::CALIB_USE_INTRINSIC_GUESS, criteria);
  return cv::norm(T);
}

}  // namespace

DistortionModel ParseDistortionModel(const std::string& name) {
  if (name == "k4") return DistortionModel::kK4;
  if (name == "k5") return DistortionModel::kK5;
  if (name == "k8") return DistortionModel::kK8;
  throw Error("unknown distortion model '" + name + "'", "--model",
              "use k4 (k1 k2 p1 p2), k5 (and k3) or k8 (the rational model)");
}

std::string StereoCalibrationOptions::Validate() const {
  if (board_cols < 3 || board_rows < 3) return "the board needs at least 3x3 inner corners";
  if (board_cols == board_rows) {
    return "a square board (" + std::to_string(board_cols) +
           " inner corners both ways) has no defined orientation; use one with unequal sides";
  }
  if (!(square_m > 0)) return "the square size must be positive (metres)";
  if (!(alpha >= 0 && alpha <= 1)) return "alpha must lie in [0, 1]";
  return "";
}

StereoCalibrationReport CalibrateStereo(const std::vector<ViewPair>& views,
                                        const StereoCalibrationOptions& options) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw Error(problem, "calibration options", "correct the board or square option");
  }
  const cv::Size board(options.board_cols, options.board_rows);
  std::vector<DetectedView> detected(views.size());
  tbb::parallel_for(size_t{0}, views.size(), [&](size_t v) { detected[v] = Detect(views[v], board); });

  StereoCalibrationReport report;
  std::vector<Corners> left, right;
  std::optional<cv::Size> image_size;
  for (size_t v = 0; v < views.size(); ++v) {
    const DetectedView& view = detected[v];
    if (view.size_left != view.size_right) {
      throw Error("the left and right images differ in size (" + SizeText(view.size_left) + " and " +
                      SizeText(view.size_right) + ")",
                  views[v].left_path + ", " + views[v].right_path, "give images from one stereo camera");
    }
    if (!image_size) image_size = view.size_left;
    if (view.size_left != *image_size) {
      throw Error("image size " + SizeText(view.size_left) + " differs from the first view's " +
                      SizeText(*image_size),
                  views[v].left_path, "give images of one camera at one resolution");
    }
    if (!view.problem.empty()) {
      report.rejected.push_back(views[v].left_path + ", " + views[v].right_path + ": " + view.problem);
      continue;
    }
    left.push_back(view.left);
    right.push_back(view.right);
    report.used.push_back(views[v]);
  }
  if (report.used.size() < 3) {
    throw Error("the board (" + std::to_string(board.width) + "x" + std::to_string(board.height) +
                    " inner corners) was found in both images of only " +
                    std::to_string(report.used.size()) + " of " + std::to_string(views.size()) + " views",
                "calibration images",
                "check --board (inner corners, not squares) and give at least 3 views, better 10 or more");
  }

  std::vector<cv::Point3f> board_points;
  for (int r = 0; r < board.height; ++r) {
    for (int c = 0; c < board.width; ++c) {
      board_points.emplace_back(c * options.square_m, r * options.square_m, 0.0f);
    }
  }
  const std::vector<std::vector<cv::Point3f>> object_points(left.size(), board_points);
  const int flags = CalibrationFlags(options.model);
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12);
  cv::Mat K1, D1, K2, D2, R, T, E, F;
  std::vector<cv::Mat> rvecs_left, tvecs_left, rvecs_right, tvecs_right;
  cv::Mat unused_deviations, per_view_left, per_view_right, per_view_stereo;
  report.rms_left_px = cv::calibrateCamera(object_points, left, *image_size, K1, D1, rvecs_left, tvecs_left,
                                           unused_deviations, unused_deviations, per_view_left, flags, criteria);
  report.rms_right_px = cv::calibrateCamera(object_points, right, *image_size, K2, D2, rvecs_right, tvecs_right,
                                            unused_deviations, unused_deviations, per_view_right, flags, criteria);
  report.rms_stereo_px = cv::stereoCalibrate(object_points, left, right, K1, D1, K2, D2, *image_size, R, T, E, F,
                                             per_view_stereo, flags | cv::CALIB_FIX_INTRINSIC, criteria);
  for (size_t v = 0; v < left.size(); ++v) {
    StereoCalibrationReport::ViewErrors& errors = report.views.emplace_back();
    errors.rms_left_px = per_view_left.at<double>(static_cast<int>(v));
    errors.rms_right_px = per_view_right.at<double>(static_cast<int>(v));
    errors.stereo_left_px = per_view_stereo.at<double>(static_cast<int>(v), 0);
    errors.stereo_right_px = per_view_stereo.at<double>(static_cast<int>(v), 1);
    errors.corner_left_px = CornerErrors(board_points, left[v], rvecs_left[v], tvecs_left[v], K1, D1);
    errors.corner_right_px = CornerErrors(board_points, right[v], rvecs_right[v], tvecs_right[v], K2, D2);
  }
  report.free_intrinsics_baseline_m = FreeIntrinsicsBaseline(object_points, left, right, K1, D1, K2, D2, *image_size,
                                                             flags, criteria);
  const double baseline_m = cv::norm(T);
  const double difference = std::abs(baseline_m - report.free_intrinsics_baseline_m) / report.free_intrinsics_baseline_m;
  if (difference > kBaselineAgreement) {
    char line[400];
    std::snprintf(line, sizeof line,
                  "the baseline with each camera's intrinsics fixed (%.3f mm) differs from stereoCalibrate's with "
                  "them free (%.3f mm) by %.1f%%: the views do not pin the pair down; add views with the board "
                  "tilted and at several distances, filling the image",
                  1e3 * baseline_m, 1e3 * report.free_intrinsics_baseline_m, 100 * difference);
    report.warnings.push_back(line);
  }

  io::StereoCalibration& calibration = report.calibration;
  calibration.left = ToCamera(K1, D1, *image_size, options.model);
  calibration.right = ToCamera(K2, D2, *image_size, options.model);
  cv::cv2eigen(R, calibration.R);
  cv::cv2eigen(T, calibration.T_m);
  calibration.rectification = stages::ComputeRectification(calibration, options.alpha);
  cv::Mat R1, R2, P1, P2;
  cv::eigen2cv(calibration.rectification->R1, R1);
  cv::eigen2cv(calibration.rectification->R2, R2);
  cv::eigen2cv(Eigen::MatrixXd(calibration.rectification->P1), P1);
  cv::eigen2cv(Eigen::MatrixXd(calibration.rectification->P2), P2);
  report.epipolar_error_px = MeanRectifiedRowError(K1, D1, R1, P1, K2, D2, R2, P2, left, right);
  return report;
}

}  // namespace dg::tools::calibrate
