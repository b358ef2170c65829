#include "stages/render/triangle_setup.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "sim/error.h"

namespace dg::stages::render {
namespace {

constexpr double kSubpixelScale = 1 << kSubpixelBits;

// Floor and ceiling of a / 2^kSubpixelBits for signed a.
int FloorPixel(std::int64_t a) { return static_cast<int>(a >> kSubpixelBits); }
int CeilPixel(std::int64_t a) { return static_cast<int>(-((-a) >> kSubpixelBits)); }

EdgeFunction MakeEdge(std::int64_t ax, std::int64_t ay, std::int64_t bx, std::int64_t by) {
  const std::int64_t dx = bx - ax, dy = by - ay;
  // With y down and the triangle on the positive side, an edge going up is a
  // left edge and a horizontal edge going right is a top edge.
  const bool top_left = dy < 0 || (dy == 0 && dx > 0);
  return {-dy << kSubpixelBits, dx << kSubpixelBits, dy * ax - dx * ay, top_left ? 0 : -1};
}

struct ProjectedVertex {
  std::int64_t x, y;
};

void AppendTriangle(const PinholeCamera& camera, const ProjectedVertex* p[3], const ClipVertex* v[3],
                    std::vector<ScreenTriangle>* triangles) {
  std::int64_t twice_area = (p[1]->x - p[0]->x) * (p[2]->y - p[0]->y) - (p[1]->y - p[0]->y) * (p[2]->x - p[0]->x);
  if (twice_area == 0) return;
  // Coverage wants the triangle on the positive side of its edges.
  const ProjectedVertex& a = *p[0];
  const ProjectedVertex& b = *p[twice_area > 0 ? 1 : 2];
  const ProjectedVertex& c = *p[twice_area > 0 ? 2 : 1];

  ScreenTriangle t;
  t.min_x = std::max(0, CeilPixel(std::min({a.x, b.x, c.x})));
  t.max_x = std::min(camera.width - 1, FloorPixel(std::max({a.x, b.x, c.x})));
  t.min_y = std::max(0, CeilPixel(std::min({a.y, b.y, c.y})));
  t.max_y = std::min(camera.height - 1, FloorPixel(std::max({a.y, b.y, c.y})));
  if (t.min_x > t.max_x || t.min_y > t.max_y) return;
  t.edge[0] = MakeEdge(b.x, b.y, c.x, c.y);
  t.edge[1] = MakeEdge(c.x, c.y, a.x, a.y);
  t.edge[2] = MakeEdge(a.x, a.y, b.x, b.y);

  const Eigen::Vector3d& p0 = v[0]->position_C;
  const Eigen::Vector3d& p1 = v[1]->position_C;
  const Eigen::Vector3d& p2 = v[2]->position_C;
  const Eigen::Vector3d normal = (p1 - p0).cross(p2 - p0);
  const double numerator = normal.dot(p0);
  if (numerator == 0) return;  // the plane holds the eye
  const double sign = numerator > 0 ? 1 : -1;
  t.depth_numerator = sign * numerator;
  const Eigen::Vector3d c_k[3] = {sign * p1.cross(p2), sign * p2.cross(p0), sign * p0.cross(p1)};
  for (int k = 0; k < 3; ++k) {
    // c . r with r = ((x - cx)/fx, (y - cy)/fy, 1), as coefficients of (x, y, 1).
    t.ray_weight[k] = {c_k[k].x() / camera.fx, c_k[k].y() / camera.fy,
                       c_k[k].z() - c_k[k].x() * camera.cx / camera.fx - c_k[k].y() * camera.cy / camera.fy};
    t.uv[k] = v[k]->uv;
    t.normal_C[k] = v[k]->normal_C;
  }
  t.min_z = static_cast<float>(std::min({p0.z(), p1.z(), p2.z()}));
  t.max_z = static_cast<float>(std::max({p0.z(), p1.z(), p2.z()}));
  triangles->push_back(t);
}

}  // namespace

void AppendScreenTriangles(const PinholeCamera& camera, const ClipPolygon& polygon,
                           std::vector<ScreenTriangle>* triangles) {
  std::array<ProjectedVertex, 9> projected;
  for (int i = 0; i < polygon.size; ++i) {
    const Eigen::Vector3d& x = polygon.vertices[i].position_C;
    const double u = camera.fx * x.x() / x.z() + camera.cx;
    const double v = camera.fy * x.y() / x.z() + camera.cy;
    DG_CHECK(std::abs(u) < (1 << 15) && std::abs(v) < (1 << 15));
    projected[i] = {std::llround(u * kSubpixelScale), std::llround(v * kSubpixelScale)};
  }
  for (int i = 1; i + 1 < polygon.size; ++i) {
    const ProjectedVertex* p[3] = {&projected[0], &projected[i], &projected[i + 1]};
    const ClipVertex* v[3] = {&polygon.vertices[0], &polygon.vertices[i], &polygon.vertices[i + 1]};
    AppendTriangle(camera, p, v, triangles);
  }
}

}  // namespace dg::stages::render
