#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "stages/constraints/nearest_point_grid.h"
#include "stages/track/feature_tracker.h"

namespace dg::stages {

// Per-frame positional constraints for the FEM stage, in the scan frame S.
struct NodeTargets {
  std::vector<int> nodes;                // constrained this frame, increasing
  std::vector<double> displacement_S_m;  // 3 per node: target displacement from the reference mesh
  std::vector<int> features;             // features averaged for each node
  int gated_features = 0;                // seen and tied, but left out this frame as outliers
};

// Maps tracked surface features to mesh-node targets (paper section 2.5). At
// the first frame each feature, brought into the scan
// frame by the registration (x_S = T_C_S^-1 x_C), is tied to its nearest free
// surface node in the mesh's geometry at that time; the ties persist for the
// run, and features first seen later are not used. In every frame a tied node's
// target is its displacement at the first frame plus the mean displacement of
// its features seen in this frame since the first; a node none of whose
// features is seen in a frame is not constrained in it. Fixed (mount) nodes are
// never candidates: the FEM stage holds them at zero.
//
// Outliers: a tracked feature can follow something that is not a material
// point (a silhouette, a shading pattern) or be matched at a wrong disparity,
// and drift millimetres off the tissue for part of each beat; tied to one node
// with free neighbours, it crushes the elements around it. Given the scan's
// prediction of every node's displacement this frame, a feature whose target
// departs from its node's prediction by more than the gate is left out of this
// frame (it is used again when it agrees). The gate is robust and adapts to how
// well the prediction holds this frame: the larger of outlier_gate_min_m and
// outlier_gate_scale times the median departure over all seen tied features,
// so a prediction that is off everywhere (a drifting cardiac phase) widens it
// instead of untying the whole surface. A second gate asks the neighbours: a
// feature whose residual (its target minus the prediction, or without one its
// target) departs from the median residual of the seen features tied within
// neighbour_radius_m of it is left out too, by the same rule (the larger of
// outlier_gate_min_m and outlier_gate_scale times the frame's median
// neighbour departure). Neighbouring tissue moves together, so a few features
// pulling a patch millimetres away from the features around it are wrong even
// when the scan's prediction is too far off to tell (docs/constraints.md).
// Stateful: frames in order, one at a time (a serial node).
class ConstraintMapper {
 public:
  struct Options {
    // A feature farther than this from every free surface node (on the mount,
    // on an instrument, or mis-triangulated) is not tied.
    double max_tie_distance_m = 3e-3;
    // Outlier gate (see above); unused without a prediction.
    double outlier_gate_min_m = 1e-3;
    double outlier_gate_scale = 3;
    // Features tied within this distance of each other (at the first frame)
    // are neighbours for the second gate: a few mesh edges, over which the
    // tissue's motion differs by much less than the gate.
    double neighbour_radius_m = 5e-3;
    std::string Validate() const;  // empty when valid
  };

  // reference_S_m: the mesh's reference nodes (3 x N); first_displacement_S_m:
  // their displacement at the first frame (the motion model at the registered
  // phase, or zero); candidates: the surface nodes; fixed: the mount's nodes.
  // @throws dg::Error for invalid options, mismatched sizes, out-of-range ids
  // or no free surface node.
  ConstraintMapper(const Options& options, const Eigen::Matrix3Xd& reference_S_m,
                   const Eigen::Matrix3Xd& first_displacement_S_m, const std::vector<int>& surface_nodes,
                   const std::vector<int>& fixed_nodes, const Eigen::Isometry3d& T_C_S);

  // The first call ties the features; every call returns this frame's targets.
  // predicted_displacement_S_m: every node's displacement this frame as the
  // scan's motion predicts it (3 x N), or null to take every tied feature.
  NodeTargets Process(const std::vector<TrackedPoint>& points,
                      const Eigen::Matrix3Xd* predicted_displacement_S_m = nullptr);
  // The same into `targets`, reusing its lists.
  void Process(const std::vector<TrackedPoint>& points, const Eigen::Matrix3Xd* predicted_displacement_S_m,
               NodeTargets* targets);

  int tied_features() const { return static_cast<int>(ties_.size()); }
  int untied_features() const { return untied_; }  // too far from the surface at the first frame
  int tied_nodes() const { return tied_nodes_; }

 private:
  struct Tie {
    int node;
    Eigen::Vector3d first_S_m;    // the feature's position at the first frame
    std::vector<int> neighbours;  // the other ties within neighbour_radius_m (indices into ties_)
    int seen_as = -1;             // this frame's index in seen_, or -1 when not seen
  };
  struct Seen {
    int tie;
    Eigen::Vector3d target_S_m;    // the node's displacement as this feature says it
    Eigen::Vector3d residual_S_m;  // the target minus the prediction (or the target, without one)
    double departure_m = 0;        // from the prediction
    double neighbour_departure_m = -1;  // from the neighbours' median residual; -1: too few seen
  };

  void TieFeatures(const std::vector<TrackedPoint>& points);
  void FindNeighbours();
  // The median neighbour residual of every seen feature with enough seen neighbours.
  void MeasureNeighbourDepartures();
  // The larger of the floor and the scale times the median of `departures` (negative ones skipped).
  double Gate(double Seen::*departure);

  Options options_;
  Eigen::Isometry3d T_S_C_;
  Eigen::Matrix3Xd first_displacement_S_m_;
  NearestPointGrid grid_;
  std::vector<Tie> ties_;
  std::unordered_map<std::int64_t, int> tie_of_feature_;
  bool first_ = true;
  int untied_ = 0, tied_nodes_ = 0;
  // Per node, this frame's sum of feature displacements and count (reset each frame).
  std::vector<Eigen::Vector3d> sum_;
  std::vector<int> count_;
  std::vector<Seen> seen_;             // this frame's tied features (reused)
  std::vector<double> scratch_;        // for medians
};

}  // namespace dg::stages
