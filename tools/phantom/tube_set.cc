#include "tools/phantom/tube_set.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dg::tools::phantom {
namespace {

double SquaredDistanceToSegment(const Eigen::Vector3d& X, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double t = std::clamp((X - a).dot(ab) / std::max(ab.squaredNorm(), 1e-30), 0.0, 1.0);
  return (a + t * ab - X).squaredNorm();
}

}  // namespace

TubeSet::TubeSet(const std::vector<Eigen::Matrix3Xd>& polylines, double radius_m) : radius_(radius_m) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::max()), hi = -lo;
  for (const Eigen::Matrix3Xd& line : polylines) {
    for (int p = 0; p + 1 < line.cols(); ++p) {
      starts_.push_back(line.col(p));
      ends_.push_back(line.col(p + 1));
    }
    lo = lo.cwiseMin(line.rowwise().minCoeff());
    hi = hi.cwiseMax(line.rowwise().maxCoeff());
  }
  if (starts_.empty()) return;
  // Cells two radii wide: each segment, grown by the radius, overlaps a few of them,
  // and a point is tested against those few only.
  cell_ = 2 * radius_;
  grid_origin_ = lo - Eigen::Vector3d::Constant(radius_);
  grid_size_ = ((hi - lo).array() / cell_ + 2).ceil().cast<int>() + 1;
  cell_segments_.resize(std::size_t(grid_size_.prod()));
  for (int s = 0; s < int(starts_.size()); ++s) {
    const Eigen::Vector3d seg_lo = starts_[s].cwiseMin(ends_[s]).array() - radius_;
    const Eigen::Vector3d seg_hi = starts_[s].cwiseMax(ends_[s]).array() + radius_;
    const Eigen::Vector3i first = ((seg_lo - grid_origin_) / cell_).array().floor().cast<int>().max(0);
    const Eigen::Vector3i last =
        ((seg_hi - grid_origin_) / cell_).array().floor().cast<int>().min(grid_size_.array() - 1);
    for (int k = first.z(); k <= last.z(); ++k)
      for (int j = first.y(); j <= last.y(); ++j)
        for (int i = first.x(); i <= last.x(); ++i) cell_segments_[CellIndex({i, j, k})].push_back(s);
  }
}

int TubeSet::CellIndex(const Eigen::Vector3i& cell) const {
  return (cell.z() * grid_size_.y() + cell.y()) * grid_size_.x() + cell.x();
}

bool TubeSet::Contains(const Eigen::Vector3d& X) const {
  if (starts_.empty()) return false;
  const Eigen::Vector3i cell = ((X - grid_origin_) / cell_).array().floor().cast<int>();
  if ((cell.array() < 0).any() || (cell.array() >= grid_size_.array()).any()) return false;
  const double r2 = radius_ * radius_;
  for (int s : cell_segments_[CellIndex(cell)]) {
    if (SquaredDistanceToSegment(X, starts_[s], ends_[s]) <= r2) return true;
  }
  return false;
}

}  // namespace dg::tools::phantom
