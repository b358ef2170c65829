#include "stages/constraints/constraint_mapper.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "sim/error.h"

namespace dg::stages {
namespace {

// A median of a few neighbours' residuals judges a feature only when a
// majority of them can outvote it and one bad neighbour cannot decide it.
constexpr int kMinSeenNeighbours = 3;

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
  if (!(neighbour_radius_m > 0)) return "neighbour_radius_m must be positive";
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
  double nearest_m = std::numeric_limits<double>::infinity();
  for (const TrackedPoint& point : points) {
    const Eigen::Vector3d x_S = T_S_C_ * point.xyz_C_m;
    const NearestPointGrid::Hit hit = grid_.Nearest(x_S);
    nearest_m = std::min(nearest_m, hit.distance_m);
    if (!(hit.distance_m <= options_.max_tie_distance_m)) {
      ++untied_;
      continue;
    }
    if (!tie_of_feature_.emplace(point.id, static_cast<int>(ties_.size())).second) continue;
    ties_.push_back({hit.id, x_S, {}});
    node_tied[hit.id] = true;
  }
  tied_nodes_ = static_cast<int>(std::count(node_tied.begin(), node_tied.end(), true));
  if (ties_.empty()) {
    // Nothing would constrain the surface for the whole run: a run of a frozen
    // or free-floating mesh, reported as a success, is a wrong answer.
    char what[200];
    std::snprintf(what, sizeof what,
                  "no tracked feature lies within %.3g mm of the mesh's free surface (%zu features, the nearest "
                  "%.4g mm away)",
                  1e3 * options_.max_tie_distance_m, points.size(), 1e3 * nearest_m);
    throw Error(what, "constraint mapper, first registered frame",
                "check the registration, the mesh's unit (mesh: {units: ...}) and the surface set; a mesh far "
                "larger or smaller than the tissue in the video is in the wrong unit");
  }
  FindNeighbours();
}

void ConstraintMapper::FindNeighbours() {
  // Once per run over a few hundred ties: the direct double loop is enough.
  const double r2 = options_.neighbour_radius_m * options_.neighbour_radius_m;
  for (size_t a = 0; a < ties_.size(); ++a) {
    for (size_t b = a + 1; b < ties_.size(); ++b) {
      if ((ties_[a].first_S_m - ties_[b].first_S_m).squaredNorm() <= r2) {
        ties_[a].neighbours.push_back(static_cast<int>(b));
        ties_[b].neighbours.push_back(static_cast<int>(a));
      }
    }
  }
}

void ConstraintMapper::MeasureNeighbourDepartures() {
  for (Seen& seen : seen_) {
    const Tie& tie = ties_[seen.tie];
    Eigen::Vector3d median;
    for (int i = 0; i < 3; ++i) {
      scratch_.clear();
      for (int b : tie.neighbours) {
        if (ties_[b].seen_as >= 0) scratch_.push_back(seen_[ties_[b].seen_as].residual_S_m[i]);
      }
      if (static_cast<int>(scratch_.size()) < kMinSeenNeighbours) break;
      const auto middle = scratch_.begin() + scratch_.size() / 2;
      std::nth_element(scratch_.begin(), middle, scratch_.end());
      median[i] = *middle;
      if (i == 2) seen.neighbour_departure_m = (seen.residual_S_m - median).norm();
    }
  }
}

double ConstraintMapper::Gate(double Seen::*departure) {
  scratch_.clear();
  for (const Seen& seen : seen_) {
    if (seen.*departure >= 0) scratch_.push_back(seen.*departure);
  }
  if (scratch_.empty()) return options_.outlier_gate_min_m;
  const auto middle = scratch_.begin() + scratch_.size() / 2;
  std::nth_element(scratch_.begin(), middle, scratch_.end());
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
  for (const Seen& seen : seen_) ties_[seen.tie].seen_as = -1;  // last frame's marks
  seen_.clear();
  for (const TrackedPoint& point : points) {
    const auto found = tie_of_feature_.find(point.id);
    if (found == tie_of_feature_.end()) continue;
    Tie& tie = ties_[found->second];
    if (tie.seen_as >= 0) continue;  // a feature id twice in one frame: the first sighting counts
    const Eigen::Vector3d target_S_m =
        first_displacement_S_m_.col(tie.node) + (T_S_C_ * point.xyz_C_m - tie.first_S_m);
    Seen seen{found->second, target_S_m, target_S_m};
    if (predicted_displacement_S_m) {
      seen.residual_S_m -= predicted_displacement_S_m->col(tie.node);
      seen.departure_m = seen.residual_S_m.norm();
    }
    tie.seen_as = static_cast<int>(seen_.size());
    seen_.push_back(seen);
  }
  MeasureNeighbourDepartures();
  const double gate_m =
      predicted_displacement_S_m ? Gate(&Seen::departure_m) : std::numeric_limits<double>::infinity();
  const double neighbour_gate_m = Gate(&Seen::neighbour_departure_m);

  std::vector<int>& touched = targets->nodes;  // sorted below: the constrained nodes
  touched.clear();
  targets->displacement_S_m.clear();
  targets->features.clear();
  targets->gated_features = 0;
  for (const Seen& seen : seen_) {
    if (seen.departure_m > gate_m || seen.neighbour_departure_m > neighbour_gate_m) {
      ++targets->gated_features;
      continue;
    }
    const int a = ties_[seen.tie].node;
    if (count_[a] == 0) {
      sum_[a].setZero();
      touched.push_back(a);
    }
    sum_[a] += seen.target_S_m;
    ++count_[a];
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
