#include "tools/phantom/chessboard.h"

#include <cmath>
#include <numbers>
#include <random>

#include <opencv2/imgproc.hpp>

#include "sim/error.h"
#include "stages/camera_model.h"

namespace dg::tools::phantom {
namespace {

constexpr int kSquaresX = Chessboard::kInnerCols + 1 + 2, kSquaresY = Chessboard::kInnerRows + 1 + 2;

bool InsideImage(const io::CameraCalibration& camera, const Eigen::Vector3d& point_C, double margin_px) {
  if (point_C.z() <= 0) return false;
  const Eigen::Vector2d uv = stages::Project(camera, point_C);
  return uv.x() >= margin_px && uv.y() >= margin_px && uv.x() <= camera.width - 1 - margin_px &&
         uv.y() <= camera.height - 1 - margin_px;
}

}  // namespace

cv::Mat Chessboard::Texture() {
  cv::Mat texture(kSquaresY * kTexelsPerSquare, kSquaresX * kTexelsPerSquare, CV_8UC3, cv::Scalar::all(235));
  // Squares of the (inner + 1) x (inner + 1) board, black at its top-left, inside the border.
  for (int row = 1; row < kSquaresY - 1; ++row) {
    for (int col = 1; col < kSquaresX - 1; ++col) {
      if ((row + col) % 2) continue;
      cv::rectangle(texture, cv::Rect(col * kTexelsPerSquare, row * kTexelsPerSquare, kTexelsPerSquare, kTexelsPerSquare),
                    cv::Scalar::all(25), cv::FILLED);
    }
  }
  return texture;
}

Eigen::Matrix3Xd Chessboard::InnerCorners_B() {
  Eigen::Matrix3Xd corners(3, kInnerCols * kInnerRows);
  for (int r = 0; r < kInnerRows; ++r) {
    for (int c = 0; c < kInnerCols; ++c) corners.col(r * kInnerCols + c) << (c + 2) * kSquare_m, (r + 2) * kSquare_m, 0;
  }
  return corners;
}

Eigen::Vector2d Chessboard::PrintSize_m() { return {kSquaresX * kSquare_m, kSquaresY * kSquare_m}; }

std::vector<Eigen::Isometry3d> SampleBoardPoses(const PhantomSpec& spec, const StereoRig& rig, int count) {
  std::mt19937_64 rng(spec.seed * 0xA0761D6478BD642FULL + 4);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const Eigen::Vector2d size = Chessboard::PrintSize_m();
  Eigen::Matrix<double, 3, 4> outline_B;
  outline_B << 0, size.x(), size.x(), 0,  //
      0, 0, size.y(), size.y(),           //
      0, 0, 0, 0;
  const Eigen::Isometry3d T_R_C = rig.T_R_C();
  const double margin_px = 0.02 * spec.width;

  std::vector<Eigen::Isometry3d> poses;
  for (int attempt = 0; static_cast<int>(poses.size()) < count; ++attempt) {
    if (attempt > 10000 * count) {
      throw Error("could not place the calibration board inside both images", "phantom calibration images",
                  "use a larger image or a wider working distance");
    }
    // Tilted up to 40 degrees about a random in-plane axis, turned up to 25
    // degrees about the optical axis, 45 to 75 mm away, anywhere in view.
    const double tilt = 40.0 * std::numbers::pi / 180 * std::abs(uniform(rng));
    const double tilt_axis = std::numbers::pi * uniform(rng);
    const double spin = 25.0 * std::numbers::pi / 180 * uniform(rng);
    const double distance = 0.060 + 0.015 * uniform(rng);
    const Eigen::Vector3d centre(0.25 * distance * uniform(rng), 0.18 * distance * uniform(rng), distance);
    Eigen::Isometry3d T_C_B = Eigen::Isometry3d::Identity();
    T_C_B.linear() = (Eigen::AngleAxisd(tilt, Eigen::Vector3d(std::cos(tilt_axis), std::sin(tilt_axis), 0)) *
                      Eigen::AngleAxisd(spin, Eigen::Vector3d::UnitZ()))
                         .toRotationMatrix();
    T_C_B.translation() = centre - T_C_B.linear() * Eigen::Vector3d(0.5 * size.x(), 0.5 * size.y(), 0);
    bool inside = true;
    for (int k = 0; k < 4 && inside; ++k) {
      const Eigen::Vector3d corner_C = T_C_B * outline_B.col(k);
      inside = InsideImage(rig.calibration.left, corner_C, margin_px) &&
               InsideImage(rig.calibration.right, T_R_C * corner_C, margin_px);
    }
    if (inside) poses.push_back(T_C_B);
  }
  return poses;
}

}  // namespace dg::tools::phantom
