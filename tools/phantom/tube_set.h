#pragma once

#include <vector>

#include <Eigen/Core>

namespace dg::tools::phantom {

// Tubes of one radius around polylines: the set of points closer than the
// radius to any segment. Points are tested against the few segments of a
// uniform grid cell only, so a CT phase's millions of samples stay cheap.
class TubeSet {
 public:
  TubeSet() = default;
  // Each polyline has at least two points (metres).
  TubeSet(const std::vector<Eigen::Matrix3Xd>& polylines, double radius_m);

  bool Contains(const Eigen::Vector3d& X) const;

 private:
  int CellIndex(const Eigen::Vector3i& cell) const;

  double radius_ = 0;
  std::vector<Eigen::Vector3d> starts_, ends_;  // segment j runs from starts_[j] to ends_[j]
  Eigen::Vector3d grid_origin_ = Eigen::Vector3d::Zero();
  Eigen::Vector3i grid_size_ = Eigen::Vector3i::Zero();
  double cell_ = 1;
  std::vector<std::vector<int>> cell_segments_;  // per cell, the segments whose tube reaches into it
};

}  // namespace dg::tools::phantom
