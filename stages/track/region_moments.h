#pragma once

#include <cmath>

#include <opencv2/core.hpp>

namespace dg::stages {

// The weighted centroid and second moments of an image region's pixels, and
// its moment ellipse: a uniform ellipse of semi-axis a has variance a^2 / 4
// along that axis. Shared by MSER features and marker finding.
class RegionMoments {
 public:
  void Add(double u, double v, double weight = 1) {
    w_ += weight, u_ += weight * u, v_ += weight * v;
    uu_ += weight * u * u, vv_ += weight * v * v, uv_ += weight * u * v;
  }

  double weight() const { return w_; }
  cv::Point2f centroid() const { return {static_cast<float>(u_ / w_), static_cast<float>(v_ / w_)}; }

  // Variances along the principal axes, largest first, and the major axis's angle (degrees from +u).
  void PrincipalAxes(double* major, double* minor, double* angle_deg) const {
    const double mu = u_ / w_, mv = v_ / w_;
    const double cuu = uu_ / w_ - mu * mu, cvv = vv_ / w_ - mv * mv, cuv = uv_ / w_ - mu * mv;
    const double half_trace = 0.5 * (cuu + cvv), root = std::hypot(0.5 * (cuu - cvv), cuv);
    *major = half_trace + root;
    *minor = half_trace - root;
    *angle_deg = 0.5 * std::atan2(2 * cuv, cuu - cvv) * 180 / CV_PI;
  }

  // Whether the region is a blob, not a line: major / minor axis at most max_elongation.
  bool Compact(double max_elongation) const {
    double major, minor, angle;
    PrincipalAxes(&major, &minor, &angle);
    return minor > 0 && major <= minor * max_elongation * max_elongation;
  }

 private:
  double w_ = 0, u_ = 0, v_ = 0, uu_ = 0, vv_ = 0, uv_ = 0;
};

}  // namespace dg::stages
