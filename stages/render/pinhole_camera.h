#pragma once

#include <string>

namespace dg::stages::render {

// A distortion-free pinhole camera: a point (x, y, z) in the camera frame C
// (x right, y down, z forward, metres) lands on pixel u = fx x/z + cx,
// v = fy y/z + cy, where (u, v) = (col, row) and (0, 0) is the centre of the
// top-left pixel (OpenCV). Only points with near_m <= z <= far_m are drawn.
// Lens distortion is the caller's: render at a higher resolution, then warp.
struct PinholeCamera {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;
  double near_m = 1e-3, far_m = 10.0;

  // Empty if the camera is usable, otherwise what is wrong with it.
  std::string Validate() const;

  // The camera of the same view sampled s x s times per pixel. Sub-pixel k of
  // pixel u sits at u - 1/2 + (k + 1/2)/s, so u_full = s u + (s - 1)/2.
  PinholeCamera Supersampled(int s) const;
};

}  // namespace dg::stages::render
