#include "stages/overlay/lens_view.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "sim/error.h"
#include "stages/camera_model.h"

namespace dg::stages::overlay {
namespace {

constexpr double kFieldMargin = 1.2;  // of the widest ray's radius

// (x_d, y_d) of normalised (x, y), the radial factor held beyond r2_limit.
Eigen::Vector2d Distort(const io::CameraCalibration& camera, double r2_limit, double x, double y) {
  const double r2 = x * x + y * y;
  const double scale = r2 > r2_limit ? std::sqrt(r2_limit / r2) : 1.0;
  Eigen::Vector2d d;
  DistortNormalized(camera.distortion.data(), x * scale, y * scale, &d.x(), &d.y());
  return d / scale;
}

}  // namespace

LensView::LensView(const io::CameraCalibration& camera, const Eigen::Isometry3d& T_C_S)
    : camera_(camera), T_C_S_(T_C_S) {
  const std::string where = "overlay camera";
  pinhole_.fx = camera.fx();
  pinhole_.fy = camera.fy();
  pinhole_.cx = camera.cx();
  pinhole_.cy = camera.cy();
  pinhole_.width = camera.width;
  pinhole_.height = camera.height;
  if (const std::string problem = pinhole_.Validate(); !problem.empty())
    throw Error("invalid calibration: " + problem, where, "give K and image_size in the calibration file");
  // The widest ray: the image's border pixels undistorted.
  double widest_r2 = 0;
  const auto visit = [&](double u, double v) {
    Eigen::Vector2d normalized;
    if (!UndistortPixel(camera, Eigen::Vector2d(u, v), &normalized))
      throw Error("lens distortion cannot be inverted at pixel (" + std::to_string(u) + ", " + std::to_string(v) + ")",
                  where, "check the distortion coefficients of the calibration");
    widest_r2 = std::max(widest_r2, normalized.squaredNorm());
  };
  for (int u = 0; u < camera.width; u += 8) {
    visit(u, 0);
    visit(u, camera.height - 1);
  }
  for (int v = 0; v < camera.height; v += 8) {
    visit(0, v);
    visit(camera.width - 1, v);
  }
  visit(camera.width - 1, camera.height - 1);
  r2_limit_ = widest_r2 * kFieldMargin * kFieldMargin;
  // One-to-one: the distorted radius grows with the radius up to the limit.
  constexpr int kSteps = 256;
  double previous = 0;
  for (int i = 1; i <= kSteps; ++i) {
    const double r = std::sqrt(r2_limit_) * i / kSteps;
    const double distorted = Distort(camera_, r2_limit_, r, 0).norm();
    if (!(distorted > previous))
      throw Error("the lens model folds over at normalised radius " + std::to_string(r) +
                      ", within the image's field of view",
                  where, "recalibrate with a distortion model that is monotonic over the image (e.g. --model k4)");
    previous = distorted;
  }
}

Eigen::Vector3d LensView::ToView(const Eigen::Vector3d& point_S) const {
  const Eigen::Vector3d p = T_C_S_ * point_S;
  if (!(p.z() > 0)) return p;  // behind the camera: the clipper drops it
  const Eigen::Vector2d d = Distort(camera_, r2_limit_, p.x() / p.z(), p.y() / p.z());
  return {d.x() * p.z(), d.y() * p.z(), p.z()};
}

template <typename Scalar>
void LensView::ToView(const Eigen::Matrix3Xd& points_S, Eigen::Matrix<Scalar, 3, Eigen::Dynamic>* view) const {
  view->resize(3, points_S.cols());
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, points_S.cols(), 1024), [&](const auto& range) {
    for (Eigen::Index p = range.begin(); p != range.end(); ++p)
      view->col(p) = ToView(Eigen::Vector3d(points_S.col(p))).template cast<Scalar>();
  });
}
template void LensView::ToView(const Eigen::Matrix3Xd&, Eigen::Matrix3Xf*) const;
template void LensView::ToView(const Eigen::Matrix3Xd&, Eigen::Matrix3Xd*) const;

cv::Mat LensView::RayLengthPerDepth() const {
  // sqrt(1 + x_u^2 + y_u^2) varies slowly over the image (tens of percent
  // from centre to corner, smoothly): the lens is inverted on a grid every
  // kStep pixels, with the last row and column at the image's edge, and
  // interpolated bilinearly between (within 3e-5 relative through a strongly
  // distorting lens, tests/stages/overlay), 16 times fewer inversions.
  constexpr int kStep = 4;
  DG_CHECK(camera_.width >= 2 && camera_.height >= 2);
  const int grid_cols = (camera_.width - 1 + kStep - 1) / kStep + 1, grid_rows = (camera_.height - 1 + kStep - 1) / kStep + 1;
  const auto grid_coordinate = [](int k, int size) { return std::min(k * kStep, size - 1); };
  cv::Mat grid(grid_rows, grid_cols, CV_64F);
  std::atomic<bool> failed{false};
  tbb::parallel_for(0, grid_rows, [&](int j) {
    for (int i = 0; i < grid_cols; ++i) {
      Eigen::Vector2d normalized;
      const Eigen::Vector2d pixel(grid_coordinate(i, camera_.width), grid_coordinate(j, camera_.height));
      if (!UndistortPixel(camera_, pixel, &normalized)) failed = true;
      grid.at<double>(j, i) = std::sqrt(1 + normalized.squaredNorm());
    }
  });
  if (failed)
    throw Error("lens distortion cannot be inverted inside the image", "overlay camera",
                "check the distortion coefficients of the calibration");
  cv::Mat length(camera_.height, camera_.width, CV_32F);
  tbb::parallel_for(0, camera_.height, [&](int v) {
    const int j = std::min(v / kStep, grid_rows - 2);
    const double y0 = grid_coordinate(j, camera_.height), y1 = grid_coordinate(j + 1, camera_.height);
    const double fy = (v - y0) / (y1 - y0);
    for (int u = 0; u < camera_.width; ++u) {
      const int i = std::min(u / kStep, grid_cols - 2);
      const double x0 = grid_coordinate(i, camera_.width), x1 = grid_coordinate(i + 1, camera_.width);
      const double fx = (u - x0) / (x1 - x0);
      const double top = (1 - fx) * grid.at<double>(j, i) + fx * grid.at<double>(j, i + 1);
      const double bottom = (1 - fx) * grid.at<double>(j + 1, i) + fx * grid.at<double>(j + 1, i + 1);
      length.at<float>(v, u) = static_cast<float>((1 - fy) * top + fy * bottom);
    }
  });
  return length;
}

LensView RightLensView(const io::StereoCalibration& stereo, const Eigen::Isometry3d& T_C_S) {
  Eigen::Isometry3d T_R_C = Eigen::Isometry3d::Identity();
  T_R_C.linear() = stereo.R;
  T_R_C.translation() = stereo.T_m;
  return LensView(stereo.right, T_R_C * T_C_S);
}

}  // namespace dg::stages::overlay
