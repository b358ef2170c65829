#include "tools/phantom/distorted_view.h"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "sim/error.h"
#include "stages/camera_model.h"

namespace dg::tools::phantom {
namespace {

// Undistorted normalised coordinates of every output pixel.
cv::Mat UndistortedRays(const io::CameraCalibration& camera) {
  cv::Mat rays(camera.height, camera.width, CV_64FC2);
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      Eigen::Vector2d normalized;
      if (!stages::UndistortPixel(camera, Eigen::Vector2d(u, v), &normalized)) {
        throw Error("lens distortion cannot be inverted at pixel (" + std::to_string(u) + ", " + std::to_string(v) + ")",
                    "phantom camera", "use milder distortion coefficients");
      }
      rays.at<cv::Vec2d>(v, u) = {normalized.x(), normalized.y()};
    }
  }
  return rays;
}

// A pinhole camera with the same focal lengths whose image covers all rays,
// with a margin of a few pixels for the resampling filter.
stages::render::PinholeCamera CoveringCamera(const io::CameraCalibration& camera, const cv::Mat& rays) {
  double min_x, max_x, min_y, max_y;
  std::vector<cv::Mat> xy;
  cv::split(rays, xy);
  cv::minMaxLoc(xy[0], &min_x, &max_x);
  cv::minMaxLoc(xy[1], &min_y, &max_y);
  constexpr double kMargin = 4;
  stages::render::PinholeCamera pinhole;
  pinhole.fx = camera.fx();
  pinhole.fy = camera.fy();
  pinhole.cx = -min_x * camera.fx() + kMargin;
  pinhole.cy = -min_y * camera.fy() + kMargin;
  pinhole.width = static_cast<int>(std::ceil((max_x - min_x) * camera.fx() + 2 * kMargin)) + 1;
  pinhole.height = static_cast<int>(std::ceil((max_y - min_y) * camera.fy() + 2 * kMargin)) + 1;
  return pinhole;
}

}  // namespace

DistortedView::DistortedView(const io::CameraCalibration& camera, int supersample)
    : camera_(camera), rays_(UndistortedRays(camera)), rasterizer_(CoveringCamera(camera, rays_), supersample) {
  const stages::render::PinholeCamera& full = rasterizer_.FullCamera();
  map_x_.create(camera.height, camera.width, CV_32F);
  map_y_.create(camera.height, camera.width, CV_32F);
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const cv::Vec2d ray = rays_.at<cv::Vec2d>(v, u);
      map_x_.at<float>(v, u) = static_cast<float>(full.fx * ray[0] + full.cx);
      map_y_.at<float>(v, u) = static_cast<float>(full.fy * ray[1] + full.cy);
    }
  }
  rays_.release();
}

cv::Mat DistortedView::Resolve() const {
  cv::Mat full = rasterizer_.ColorFull();
  const int s = rasterizer_.supersample();
  if (s > 1) cv::GaussianBlur(full, full, cv::Size(), 0.5 * s);  // about one output pixel wide
  cv::Mat image;
  cv::remap(full, image, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return image;
}

std::vector<uint8_t> DistortedView::Visible(const Eigen::Matrix3Xd& points_C, double tolerance_m) const {
  const stages::render::PinholeCamera& full = rasterizer_.FullCamera();
  const cv::Mat depth = rasterizer_.Depth();
  std::vector<uint8_t> visible(points_C.cols(), 0);
  for (Eigen::Index p = 0; p < points_C.cols(); ++p) {
    const Eigen::Vector3d point = points_C.col(p);
    if (point.z() <= 0) continue;
    const Eigen::Vector2d uv = stages::Project(camera_, point);
    if (uv.x() < -0.5 || uv.y() < -0.5 || uv.x() > camera_.width - 0.5 || uv.y() > camera_.height - 0.5) continue;
    const int col = static_cast<int>(std::lround(full.fx * point.x() / point.z() + full.cx));
    const int row = static_cast<int>(std::lround(full.fy * point.y() / point.z() + full.cy));
    if (col < 0 || row < 0 || col >= full.width || row >= full.height) continue;
    visible[p] = point.z() <= depth.at<float>(row, col) + tolerance_m;
  }
  return visible;
}

}  // namespace dg::tools::phantom
