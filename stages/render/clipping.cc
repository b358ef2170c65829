#include "stages/render/clipping.h"

#include <utility>

namespace dg::stages::render {

FrustumClipper::FrustumClipper(const PinholeCamera& camera, double guard_px) {
  const double u_min = -guard_px, u_max = camera.width - 1 + guard_px;
  const double v_min = -guard_px, v_max = camera.height - 1 + guard_px;
  planes_[0] = {0, 0, 1, -camera.near_m};
  planes_[1] = {0, 0, -1, camera.far_m};
  // u >= u_min  <=>  fx x + (cx - u_min) z >= 0 for z > 0; likewise the others.
  planes_[2] = {camera.fx, 0, camera.cx - u_min, 0};
  planes_[3] = {-camera.fx, 0, u_max - camera.cx, 0};
  planes_[4] = {0, camera.fy, camera.cy - v_min, 0};
  planes_[5] = {0, -camera.fy, v_max - camera.cy, 0};
}

unsigned FrustumClipper::OutCode(const Eigen::Vector3d& p) const {
  unsigned code = 0;
  for (int i = 0; i < kNumPlanes; ++i) {
    const double distance = planes_[i].head<3>().dot(p) + planes_[i][3];
    if (!(distance >= 0)) code |= 1u << i;
  }
  return code;
}

void FrustumClipper::Clip(const std::array<ClipVertex, 3>& triangle, ClipPolygon* polygon) const {
  const unsigned codes[3] = {OutCode(triangle[0].position_C), OutCode(triangle[1].position_C),
                             OutCode(triangle[2].position_C)};
  polygon->size = 0;
  if (codes[0] & codes[1] & codes[2]) return;  // all three outside one plane
  for (int k = 0; k < 3; ++k) polygon->vertices[k] = triangle[k];
  polygon->size = 3;
  const unsigned crossed = codes[0] | codes[1] | codes[2];
  if (crossed == 0) return;

  // Sutherland-Hodgman, one plane at a time, only against the planes crossed.
  ClipPolygon scratch;
  ClipPolygon* in = polygon;
  ClipPolygon* out = &scratch;
  for (int i = 0; i < kNumPlanes; ++i) {
    if (!(crossed & (1u << i))) continue;
    const Eigen::Vector4d& plane = planes_[i];
    out->size = 0;
    for (int a = 0; a < in->size; ++a) {
      const ClipVertex& va = in->vertices[a];
      const ClipVertex& vb = in->vertices[(a + 1) % in->size];
      const double da = plane.head<3>().dot(va.position_C) + plane[3];
      const double db = plane.head<3>().dot(vb.position_C) + plane[3];
      const bool a_inside = da >= 0, b_inside = db >= 0;
      if (a_inside) out->vertices[out->size++] = va;
      if (a_inside != b_inside) {
        const ClipVertex& inside = a_inside ? va : vb;
        const ClipVertex& outside = a_inside ? vb : va;
        const double d_inside = a_inside ? da : db, d_outside = a_inside ? db : da;
        const double t = d_inside / (d_inside - d_outside);
        const float tf = static_cast<float>(t);
        ClipVertex& v = out->vertices[out->size++];
        v.position_C = inside.position_C + t * (outside.position_C - inside.position_C);
        v.uv = inside.uv + tf * (outside.uv - inside.uv);
        v.normal_C = inside.normal_C + tf * (outside.normal_C - inside.normal_C);
      }
    }
    std::swap(in, out);
    if (in->size < 3) {
      polygon->size = 0;
      return;
    }
  }
  if (in != polygon) *polygon = *in;
}

}  // namespace dg::stages::render
