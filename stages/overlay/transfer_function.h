#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace dg::stages::overlay {

// What a CT number looks like in the volume overlay: an emitted colour and an
// extinction coefficient sigma (per metre of ray), so that a slab of
// thickness ds is opaque by 1 - exp(-sigma ds) whatever the slice spacing
// (Max, "Optical models for direct volume rendering", 1995). Piecewise linear
// between control points, constant beyond the first and last.
struct TransferFunction {
  struct Point {
    float hu = 0;
    Eigen::Vector3f bgr{1, 1, 1};
    float sigma_per_m = 0;
  };
  std::vector<Point> points;  // strictly increasing hu

  // Empty when valid (at least one point, increasing, finite, sigma >= 0, colours in [0, 1]).
  std::string Validate() const;
  Point At(float hu) const;

  // For contrast CT of the heart: air and fat clear, myocardium a faint red
  // haze, contrast-filled chambers (200 HU and up) opaque blue, bone and
  // metal (beads) white.
  static TransferFunction CardiacDefault();
};

}  // namespace dg::stages::overlay
