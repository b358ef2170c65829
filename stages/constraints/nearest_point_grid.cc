#include "stages/constraints/nearest_point_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/error.h"

namespace dg::stages {

NearestPointGrid::NearestPointGrid(const Eigen::Matrix3Xd& points_m, std::vector<int> ids)
    : points_m_(points_m), ids_(std::move(ids)) {
  const Eigen::Index n = points_m_.cols();
  if (n == 0 || size_t(n) != ids_.size()) {
    throw Error("nearest-point grid needs at least one point and one id per point (got " + std::to_string(n) +
                    " points, " + std::to_string(ids_.size()) + " ids)",
                "nearest-point grid", "give the candidate points with their ids");
  }
  if (!points_m_.allFinite()) throw Error("a point is not finite", "nearest-point grid", "check the node positions");
  origin_m_ = points_m_.rowwise().minCoeff();
  const Eigen::Vector3d extent = (points_m_.rowwise().maxCoeff() - origin_m_).cwiseMax(1e-9);
  // About two points per cell over the bounding box (surface points fill it sparsely, which only costs memory).
  cell_m_ = std::max(std::cbrt(extent.prod() * 2.0 / double(n)), extent.maxCoeff() / 256.0);
  for (int i = 0; i < 3; ++i) dims_[i] = std::max(1, static_cast<int>(std::ceil(extent[i] / cell_m_)));
  const int cells = dims_.prod();
  std::vector<int> cell_of(n);
  cell_begin_.assign(cells + 1, 0);
  for (Eigen::Index p = 0; p < n; ++p) {
    const Eigen::Vector3i c = CellOf(points_m_.col(p));
    cell_of[p] = (c.z() * dims_.y() + c.y()) * dims_.x() + c.x();
    ++cell_begin_[cell_of[p] + 1];
  }
  for (int c = 0; c < cells; ++c) cell_begin_[c + 1] += cell_begin_[c];
  order_.resize(n);
  std::vector<int> fill(cell_begin_.begin(), cell_begin_.end() - 1);
  for (Eigen::Index p = 0; p < n; ++p) order_[fill[cell_of[p]]++] = static_cast<int>(p);
}

Eigen::Vector3i NearestPointGrid::CellOf(const Eigen::Vector3d& x_m) const {
  Eigen::Vector3i c;
  for (int i = 0; i < 3; ++i) {
    const double f = std::floor((x_m[i] - origin_m_[i]) / cell_m_);
    c[i] = static_cast<int>(std::clamp(f, 0.0, double(dims_[i] - 1)));
  }
  return c;
}

NearestPointGrid::Hit NearestPointGrid::Nearest(const Eigen::Vector3d& x_m) const {
  const Eigen::Vector3i centre = CellOf(x_m);
  double best_sq = std::numeric_limits<double>::infinity();
  int best = -1;
  const int max_radius = dims_.maxCoeff();
  for (int r = 0; r <= max_radius; ++r) {
    // Shell r: cells at Chebyshev distance exactly r from the centre cell.
    for (int z = centre.z() - r; z <= centre.z() + r; ++z) {
      if (z < 0 || z >= dims_.z()) continue;
      for (int y = centre.y() - r; y <= centre.y() + r; ++y) {
        if (y < 0 || y >= dims_.y()) continue;
        const bool face = std::abs(z - centre.z()) == r || std::abs(y - centre.y()) == r;
        for (int x = centre.x() - r; x <= centre.x() + r; x += (face || r == 0) ? 1 : 2 * r) {
          if (x < 0 || x >= dims_.x()) continue;
          const int cell = (z * dims_.y() + y) * dims_.x() + x;
          for (int k = cell_begin_[cell]; k < cell_begin_[cell + 1]; ++k) {
            const int p = order_[k];
            const double d_sq = (points_m_.col(p) - x_m).squaredNorm();
            if (d_sq < best_sq || (d_sq == best_sq && p < best)) best_sq = d_sq, best = p;
          }
        }
      }
    }
    // Cells beyond shell r lie at least r cells from the query's cell.
    const double reach = r * cell_m_;
    if (best >= 0 && best_sq <= reach * reach) break;
  }
  return {ids_[best], std::sqrt(best_sq)};
}

}  // namespace dg::stages
