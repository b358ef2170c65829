#pragma once

#include <vector>

#include <Eigen/Core>

namespace dg::stages {

// Nearest-neighbour queries against a fixed set of 3D points, by a uniform
// grid of buckets (about two points per cell): a query searches shells of
// cells around its own until no unsearched cell can hold a closer point.
// Immutable after construction; Nearest() is const and thread-safe.
class NearestPointGrid {
 public:
  // points_m: one column per point; ids: what Nearest() returns for each (same count).
  // @throws dg::Error when there are no points, the counts differ or a point is not finite.
  NearestPointGrid(const Eigen::Matrix3Xd& points_m, std::vector<int> ids);

  struct Hit {
    int id = -1;
    double distance_m = 0;
  };
  // The point nearest to x (ties: the lower column); any x, inside the grid or not.
  Hit Nearest(const Eigen::Vector3d& x_m) const;

 private:
  Eigen::Vector3i CellOf(const Eigen::Vector3d& x_m) const;  // clamped into the grid

  Eigen::Matrix3Xd points_m_;
  std::vector<int> ids_;
  Eigen::Vector3d origin_m_;
  double cell_m_ = 0;
  Eigen::Vector3i dims_;
  std::vector<int> cell_begin_;  // points of cell c: order_[cell_begin_[c] .. cell_begin_[c + 1])
  std::vector<int> order_;
};

}  // namespace dg::stages
