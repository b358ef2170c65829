#pragma once

#include <array>

#include <Eigen/Core>

#include "stages/render/pinhole_camera.h"

namespace dg::stages::render {

// A vertex with the attributes that are linear over a triangle in 3D, so that
// a vertex made by clipping gets them by the same interpolation as its position.
struct ClipVertex {
  Eigen::Vector3d position_C;
  Eigen::Vector2f uv;
  Eigen::Vector3f normal_C;
};

// A convex polygon: a triangle cut by up to six planes has at most nine corners.
struct ClipPolygon {
  std::array<ClipVertex, 9> vertices;
  int size = 0;
};

// Clips triangles in the camera frame to the view frustum widened by a guard
// band: near_m <= z <= far_m and pixel coordinates within guard_px of the
// image. Clipping in 3D before the perspective divide is what lets a triangle
// that crosses the camera plane be drawn in part; the guard band keeps the
// projected vertices small enough for the rasterizer's fixed-point edge
// functions while its cut edges stay off the image.
//
// Watertight: a new vertex on an edge is always interpolated from the edge's
// inside end towards its outside end, so two triangles sharing the edge make
// bit-identical vertices.
class FrustumClipper {
 public:
  FrustumClipper(const PinholeCamera& camera, double guard_px);

  // Writes the part of the triangle inside the frustum to *polygon; size 0 if
  // none (cheap when the triangle is wholly behind, beyond or beside the view).
  void Clip(const std::array<ClipVertex, 3>& triangle, ClipPolygon* polygon) const;

 private:
  static constexpr int kNumPlanes = 6;
  // Bit p set: the point is outside plane p. NaN counts as outside every plane.
  unsigned OutCode(const Eigen::Vector3d& p) const;

  // Planes (n, d), inside where n.p + d >= 0: near, far, left, right, top, bottom.
  std::array<Eigen::Vector4d, kNumPlanes> planes_;
};

}  // namespace dg::stages::render
