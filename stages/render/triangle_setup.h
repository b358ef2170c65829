#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "stages/render/clipping.h"
#include "stages/render/pinhole_camera.h"

namespace dg::stages::render {

// Vertices are snapped to 1/256 pixel so that edge functions are exact
// integers: two triangles sharing an edge then agree on every pixel centre's
// side of it, and the top-left rule settles centres exactly on it.
inline constexpr int kSubpixelBits = 8;

// E(X, Y) = step_x X + step_y Y + offset at pixel centre (X, Y), in units of
// 1/256^2 pixel^2: twice the signed area of (a, b, pixel) for the edge a -> b.
// bias is 0 on top and left edges and -1 on the others, so that a centre is
// covered iff E + bias >= 0 for all three edges (the top-left fill rule).
struct EdgeFunction {
  std::int64_t step_x, step_y, offset, bias;
  std::int64_t At(int x, int y) const { return step_x * x + step_y * y + offset; }
};

// A triangle ready to rasterize in the (supersampled) image.
//
// Coverage comes from the snapped vertices, oriented so that the edge
// functions are non-negative inside. Interpolation does not: with P_k the
// vertices in the camera frame and r = ((x - cx)/fx, (y - cy)/fy, 1) the ray
// through pixel (x, y), the ray meets the triangle's plane at barycentrics
// b_k = d_k / (d_0 + d_1 + d_2), d_k = r . (P_{k+1} x P_{k+2}) (indices mod 3),
// and depth z = (N . P_0) / (d_0 + d_1 + d_2), N = (P_1 - P_0) x (P_2 - P_0).
// Each d_k is affine in (x, y), so this is perspective-correct interpolation,
// and it is exact however the vertices were snapped (depth ground truth at
// grazing angles depends on that).
struct ScreenTriangle {
  std::array<EdgeFunction, 3> edge;
  int min_x, min_y, max_x, max_y;         // pixel bounds, clipped to the image; non-empty
  std::array<Eigen::Vector3d, 3> ray_weight;  // d_k = ray_weight[k] . (x, y, 1), positive inside
  double depth_numerator;                 // N . P_0, positive (N turned to face away from the eye)
  float min_z, max_z;                     // bounds the depth against round-off at the rim of an edge-on sliver
  std::array<Eigen::Vector2f, 3> uv;
  std::array<Eigen::Vector3f, 3> normal_C;
};

// Projects a clipped polygon (all of it at z >= near, inside the guard band)
// and appends its fan of triangles, dropping those seen edge-on, those of zero
// area and those whose bounds hold no pixel centre of the image.
// @pre polygon->size == 0 or >= 3; |projected coordinates| < 2^15 pixels.
void AppendScreenTriangles(const PinholeCamera& camera, const ClipPolygon& polygon,
                           std::vector<ScreenTriangle>* triangles);

}  // namespace dg::stages::render
