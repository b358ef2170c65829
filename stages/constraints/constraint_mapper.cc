#include "stages/constraints/constraint_mapper.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/error.h"

namespace dg::stages {
namespace {

// The free surface nodes and their positions at the first frame.
NearestPointGrid MakeGrid(const Eigen::Matrix3Xd& reference_S_m, const Eigen::Matrix3Xd& first_displacement_S_m,
                          const std::vector<int>& surface_nodes, const std::vector<int>& fixed_nodes) {
  const Eigen::Index N = reference_S_m.cols();
  if (first_displacement_S_m.cols() != N) {
    throw Error("first-frame displacement has " + std::to_string(first_displacement_S_m.cols()) +
                    " nodes, the mesh " + std::to_string(N),
                "constraint mapper", "give one displacement per mesh node");
  }
  std::vector<int> fixed = fixed_nodes;
  std::sort(fixed.begin(), fixed.end());
  std::vector<int> ids;
  for (int a : surface_nodes) {
    if (a < 0 || a >= N) {
      throw Error("surface node " + std::to_string(a) + " is out of range", "constraint mapper",
                  "give node ids of this mesh");
    }
    if (!std::binary_search(fixed.begin(), fixed.end(), a)) ids.push_back(a);
  }
  if (ids.empty()) {
    throw Error("no free surface node to tie features to", "constraint mapper",
                "check the scene's surface_set and fixed_set");
  }
  Eigen::Matrix3Xd points(3, ids.size());
  for (size_t k = 0; k < ids.size(); ++k) points.col(k) = reference_S_m.col(ids[k]) + first_displacement_S_m.col(ids[k]);
  return NearestPointGrid(points, std::move(ids));
}

}  // namespace

std::string ConstraintMapper::Options::Validate() const {
  if (!(max_tie_distance_m > 0)) return "max_tie_distance_m must be positive";
  if (!(outlier_gate_min_m > 0)) return "outlier_gate_min_m must be positive";
  if (!(outlier_gate_scale >= 1)) return "outlier_gate_scale must be at least 1 (times the median departure)";
  return {};
}

ConstraintMapper::ConstraintMapper(const Options& options, const Eigen::Matrix3Xd& reference_S_m,
                                   const Eigen::Matrix3Xd& first_displacement_S_m,
                                   const std::vector<int>& surface_nodes, const std::vector<int>& fixed_nodes,
                                   const Eigen::Isometry3d& T_C_S)
    : options_(options),
      T_S_C_(T_C_S.inverse()),
      first_displacement_S_m_(first_displacement_S_m),
      grid_(MakeGrid(reference_S_m, first_displacement_S_m, surface_nodes, fixed_nodes)),
      sum_(reference_S_m.cols()),
      count_(reference_S_m.cols(), 0) {
  if (const std::string problem = options_.Validate(); !problem.empty()) {
    throw Error("invalid constraint mapping options: " + problem, "constraint mapper", "correct the option");
  }
}

NodeTargets ConstraintMapper::Process(const std::vector<TrackedPoint>& points,
                                      const Eigen::Matrix3Xd* predicted_displacement_S_m) {
  NodeTargets targets;
  Process(points, predicted_displacement_S_m, &targets);
  return targets;
}

void ConstraintMapper::TieFeatures(const std::vector<TrackedPoint>& points) {
  std::vector<bool> node_tied(count_.size(), false);
  for (const TrackedPoint& point : points) {
    const Eigen::Vector3d x_S = T_S_C_ * point.xyz_C_m;
    const NearestPointGrid::Hit hit = grid_.Nearest(x_S);
    if (!(hit.distance_m <= options_.max_tie_distance_m)) {
      ++untied_;
      continue;
    }
    ties_[point.id] = {hit.id, x_S};
    node_tied[hit.id] = true;
  }
  tied_nodes_ = static_cast<int>(std::count(node_tied.begin(), node_tied.end(), true));
}

double ConstraintMapper::Gate(const Eigen::Matrix3Xd& predicted_displacement_S_m) {
  departures_m_.clear();
  for (const Seen& seen : seen_) {
    departures_m_.push_back((seen.target_S_m - predicted_displacement_S_m.col(seen.node)).norm());
  }
  if (departures_m_.empty()) return options_.outlier_gate_min_m;
  const auto middle = departures_m_.begin() + departures_m_.size() / 2;
  std::nth_element(departures_m_.begin(), middle, departures_m_.end());
  return std::max(options_.outlier_gate_min_m, options_.outlier_gate_scale * *middle);
}

void ConstraintMapper::Process(const std::vector<TrackedPoint>& points,
                               const Eigen::Matrix3Xd* predicted_displacement_S_m, NodeTargets* targets) {
  if (predicted_displacement_S_m && predicted_displacement_S_m->cols() != first_displacement_S_m_.cols()) {
    throw Error("the prediction has " + std::to_string(predicted_displacement_S_m->cols()) + " nodes, the mesh " +
                    std::to_string(first_displacement_S_m_.cols()),
                "constraint mapper", "predict every node of the mesh");
  }
  if (first_) {
    first_ = false;
    TieFeatures(points);
  }
  seen_.clear();
  for (const TrackedPoint& point : points) {
    const auto tie = ties_.find(point.id);
    if (tie == ties_.end()) continue;
    const int a = tie->second.node;
    seen_.push_back({a, first_displacement_S_m_.col(a) + (T_S_C_ * point.xyz_C_m - tie->second.first_S_m)});
  }
  const double gate_m =
      predicted_displacement_S_m ? Gate(*predicted_displacement_S_m) : std::numeric_limits<double>::infinity();

  std::vector<int>& touched = targets->nodes;  // sorted below: the constrained nodes
  touched.clear();
  targets->displacement_S_m.clear();
  targets->features.clear();
  targets->gated_features = 0;
  for (const Seen& seen : seen_) {
    if (predicted_displacement_S_m &&
        (seen.target_S_m - predicted_displacement_S_m->col(seen.node)).norm() > gate_m) {
      ++targets->gated_features;
      continue;
    }
    if (count_[seen.node] == 0) {
      sum_[seen.node].setZero();
      touched.push_back(seen.node);
    }
    sum_[seen.node] += seen.target_S_m;
    ++count_[seen.node];
  }
  std::sort(touched.begin(), touched.end());
  for (int a : touched) {
    const Eigen::Vector3d u = sum_[a] / count_[a];
    targets->displacement_S_m.insert(targets->displacement_S_m.end(), u.data(), u.data() + 3);
    targets->features.push_back(count_[a]);
    count_[a] = 0;
  }
}

}  // namespace dg::stages
