#include "stages/render/pinhole_camera.h"

#include <cmath>

namespace dg::stages::render {

std::string PinholeCamera::Validate() const {
  if (!(std::isfinite(fx) && std::isfinite(fy) && fx > 0 && fy > 0))
    return "focal lengths fx, fy must be positive and finite";
  if (!(std::isfinite(cx) && std::isfinite(cy))) return "principal point cx, cy must be finite";
  if (width <= 0 || height <= 0) return "width and height must be positive";
  if (!(near_m > 0 && near_m < far_m && std::isfinite(far_m)))
    return "clip distances must satisfy 0 < near_m < far_m < inf";
  return {};
}

PinholeCamera PinholeCamera::Supersampled(int s) const {
  PinholeCamera full = *this;
  full.fx = fx * s;
  full.fy = fy * s;
  full.cx = cx * s + (s - 1) / 2.0;
  full.cy = cy * s + (s - 1) / 2.0;
  full.width = width * s;
  full.height = height * s;
  return full;
}

}  // namespace dg::stages::render
