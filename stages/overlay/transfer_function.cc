#include "stages/overlay/transfer_function.h"

#include <cmath>

namespace dg::stages::overlay {

std::string TransferFunction::Validate() const {
  if (points.empty()) return "a transfer function needs at least one control point";
  for (size_t i = 0; i < points.size(); ++i) {
    const Point& p = points[i];
    const std::string which = "control point " + std::to_string(i);
    if (!std::isfinite(p.hu) || !std::isfinite(p.sigma_per_m) || !p.bgr.allFinite()) return which + " is not finite";
    if (p.sigma_per_m < 0) return which + " has a negative extinction";
    if (p.bgr.minCoeff() < 0 || p.bgr.maxCoeff() > 1) return which + " has a colour outside [0, 1]";
    if (i > 0 && !(p.hu > points[i - 1].hu)) return which + " does not increase in HU";
  }
  return {};
}

TransferFunction::Point TransferFunction::At(float hu) const {
  if (hu <= points.front().hu) return points.front();
  if (hu >= points.back().hu) return points.back();
  size_t i = 1;
  while (points[i].hu < hu) ++i;
  const Point& a = points[i - 1];
  const Point& b = points[i];
  const float t = (hu - a.hu) / (b.hu - a.hu);
  return {hu, (1 - t) * a.bgr + t * b.bgr, (1 - t) * a.sigma_per_m + t * b.sigma_per_m};
}

TransferFunction TransferFunction::CardiacDefault() {
  TransferFunction f;
  f.points = {
      {-200, {0.0f, 0.0f, 0.0f}, 0},
      {0, {0.3f, 0.3f, 0.8f}, 5},
      {120, {0.3f, 0.3f, 0.8f}, 15},
      {200, {1.0f, 0.55f, 0.2f}, 600},
      {1000, {1.0f, 0.8f, 0.5f}, 1500},
      {2000, {1.0f, 1.0f, 1.0f}, 4000},
  };
  return f;
}

}  // namespace dg::stages::overlay
