// Constraint mapping against hand-computed truths: nearest nodes by brute
// force, targets as first-frame displacement plus the mean feature displacement.
#include "stages/constraints/constraint_mapper.h"

#include <algorithm>
#include <random>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>

#include "sim/error.h"

namespace dg::stages {
namespace {

using Catch::Matchers::Contains;

Eigen::Matrix3Xd RandomPoints(int n, std::mt19937* rng, double scale) {
  std::uniform_real_distribution<double> unit(-1, 1);
  Eigen::Matrix3Xd points(3, n);
  for (int p = 0; p < n; ++p) points.col(p) = scale * Eigen::Vector3d(unit(*rng), unit(*rng), 0.3 * unit(*rng));
  return points;
}

// The grid answers exactly what a scan over all points answers, for queries
// inside, on the edge of and far outside the points' box.
TEST_CASE("nearest point grid: same answers as brute force", "[unit]") {
  std::mt19937 rng(3);
  const Eigen::Matrix3Xd points = RandomPoints(700, &rng, 0.02);
  std::vector<int> ids(points.cols());
  for (size_t p = 0; p < ids.size(); ++p) ids[p] = 1000 + static_cast<int>(p);
  const NearestPointGrid grid(points, ids);
  for (double reach : {0.5, 1.0, 5.0}) {
    const Eigen::Matrix3Xd queries = RandomPoints(300, &rng, 0.02 * reach);
    for (Eigen::Index q = 0; q < queries.cols(); ++q) {
      Eigen::Index best;
      const double distance = (points.colwise() - queries.col(q)).colwise().norm().minCoeff(&best);
      const NearestPointGrid::Hit hit = grid.Nearest(queries.col(q));
      REQUIRE(hit.distance_m == Approx(distance).epsilon(1e-12));
      REQUIRE(hit.id == ids[best]);
    }
  }
  REQUIRE_THROWS_WITH(NearestPointGrid(Eigen::Matrix3Xd(3, 0), {}), Contains("at least one point"));
}

struct Scene {
  Eigen::Matrix3Xd X_S, first_u_S;
  std::vector<int> surface, fixed;
  Eigen::Isometry3d T_C_S;
};

// Six nodes on a line 10 mm apart; nodes 0 and 1 are the mount; node 5 is interior.
Scene MakeScene() {
  Scene s;
  s.X_S = Eigen::Matrix3Xd::Zero(3, 6);
  for (int a = 0; a < 6; ++a) s.X_S(0, a) = 0.01 * a;
  s.first_u_S = Eigen::Matrix3Xd::Zero(3, 6);
  for (int a = 0; a < 6; ++a) s.first_u_S(1, a) = 1e-3 * a;
  s.surface = {0, 1, 2, 3, 4};
  s.fixed = {0, 1};
  s.T_C_S = Eigen::Translation3d(0.01, -0.02, 0.08) * Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, -2, 0.5).normalized());
  return s;
}

TrackedPoint Feature(std::int64_t id, const Scene& s, const Eigen::Vector3d& x_S) {
  TrackedPoint point;
  point.id = id;
  point.xyz_C_m = s.T_C_S * x_S;
  return point;
}

// Node 0 the mount, every other node free surface, at rest; the camera 8 cm away.
Scene MountAndSurface(const Eigen::Matrix3Xd& X_S) {
  Scene s;
  s.X_S = X_S;
  s.first_u_S = Eigen::Matrix3Xd::Zero(3, X_S.cols());
  for (int a = 1; a < X_S.cols(); ++a) s.surface.push_back(a);
  s.fixed = {0};
  s.T_C_S = Eigen::Isometry3d(Eigen::Translation3d(0, 0, 0.08));
  return s;
}

// A mapper with the default options whose first frame ties feature a to surface node a.
ConstraintMapper TieEveryNode(const Scene& s) {
  ConstraintMapper mapper({}, s.X_S, s.first_u_S, s.surface, s.fixed, s.T_C_S);
  std::vector<TrackedPoint> first;
  for (int a : s.surface) first.push_back(Feature(a, s, s.X_S.col(a)));
  mapper.Process(first);
  return mapper;
}

// Ties at the first frame to the nearest free surface node in the first
// frame's geometry; targets are the node's first displacement plus the mean
// of its features' displacements seen now; lost features drop out, a node
// with none left is not constrained, late features and far ones are ignored.
TEST_CASE("constraint mapper: persistent ties, mean displacement, lost features drop out", "[unit]") {
  const Scene s = MakeScene();
  ConstraintMapper mapper({3e-3}, s.X_S, s.first_u_S, s.surface, s.fixed, s.T_C_S);
  auto at_node = [&](int a, const Eigen::Vector3d& offset) {
    return Eigen::Vector3d(s.X_S.col(a) + s.first_u_S.col(a) + offset);
  };
  const Eigen::Vector3d off(0.5e-3, -0.4e-3, 0.2e-3);
  std::vector<TrackedPoint> first = {
      Feature(10, s, at_node(2, off)),  Feature(11, s, at_node(2, -off)), Feature(12, s, at_node(3, off)),
      Feature(13, s, at_node(1, off)),   // on the mount: its nearest free node (2) is 10 mm away, untied
      Feature(14, s, at_node(4, Eigen::Vector3d(0, 0, 0.01))),  // 10 mm off the surface: untied
  };
  const NodeTargets at_first = mapper.Process(first);
  REQUIRE(mapper.tied_features() == 3);
  REQUIRE(mapper.untied_features() == 2);
  REQUIRE(mapper.tied_nodes() == 2);
  REQUIRE(at_first.nodes == std::vector<int>{2, 3});
  for (size_t k = 0; k < 2; ++k) {
    for (int i = 0; i < 3; ++i) REQUIRE(at_first.displacement_S_m[3 * k + i] == Approx(s.first_u_S(i, at_first.nodes[k])).margin(1e-15));
  }

  // Later: feature 10 moves by d1, 11 by d2, 12 is lost, 15 is new (ignored).
  const Eigen::Vector3d d1(1e-3, 0, 0), d2(0, 2e-3, -1e-3);
  std::vector<TrackedPoint> later = {Feature(10, s, at_node(2, off + d1)), Feature(11, s, at_node(2, -off + d2)),
                                     Feature(15, s, at_node(3, off))};
  const NodeTargets moved = mapper.Process(later);
  REQUIRE(moved.nodes == std::vector<int>{2});
  REQUIRE(moved.features == std::vector<int>{2});
  const Eigen::Vector3d expected = s.first_u_S.col(2) + 0.5 * (d1 + d2);
  for (int i = 0; i < 3; ++i) REQUIRE(moved.displacement_S_m[i] == Approx(expected[i]).margin(1e-15));

  // Feature 12 comes back: node 3 is constrained again.
  const NodeTargets back = mapper.Process({Feature(12, s, at_node(3, off + d1))});
  REQUIRE(back.nodes == std::vector<int>{3});
  for (int i = 0; i < 3; ++i) REQUIRE(back.displacement_S_m[i] == Approx(s.first_u_S(i, 3) + d1[i]).margin(1e-15));
}

// The outlier gate against the scan's prediction: a feature that drifts 3 mm
// off the tissue is left out while the others (0.2 mm of tracking noise) are
// kept; when the prediction itself is off everywhere by 1.5 mm the gate widens
// with the median and leaves no feature out but a 6 mm outlier.
TEST_CASE("constraint mapper: features departing from the prediction are gated", "[unit]") {
  const int n = 21;
  Eigen::Matrix3Xd X_S = Eigen::Matrix3Xd::Zero(3, n);
  for (int a = 0; a < n; ++a) X_S(0, a) = 0.01 * a;
  const Scene s = MountAndSurface(X_S);
  ConstraintMapper mapper = TieEveryNode(s);

  // The tissue moves by `motion`; each feature sees it with up to 0.2 mm of noise, feature 7 with 3 mm more.
  const Eigen::Vector3d motion(1e-3, 2e-3, -0.5e-3);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> noise(-0.2e-3, 0.2e-3);
  auto frame = [&](double outlier_m) {
    std::vector<TrackedPoint> seen;
    for (int a = 1; a < n; ++a) {
      Eigen::Vector3d x = s.X_S.col(a) + motion + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      if (a == 7) x.z() += outlier_m;
      seen.push_back(Feature(a, s, x));
    }
    return seen;
  };
  Eigen::Matrix3Xd predicted = motion.replicate(1, n);
  const NodeTargets gated = mapper.Process(frame(3e-3), &predicted);
  REQUIRE(gated.gated_features == 1);
  REQUIRE(gated.nodes.size() == n - 2);
  REQUIRE(std::find(gated.nodes.begin(), gated.nodes.end(), 7) == gated.nodes.end());
  REQUIRE(mapper.Process(frame(0), &predicted).gated_features == 0);  // back in when it agrees
  REQUIRE(mapper.Process(frame(3e-3)).gated_features == 0);  // no prediction, no neighbour within 5 mm: no gate

  predicted.row(0).array() -= 1.5e-3;  // a prediction off everywhere: the gate widens to 3 x 1.5 mm
  REQUIRE(mapper.Process(frame(3e-3), &predicted).gated_features == 0);
  REQUIRE(mapper.Process(frame(6e-3), &predicted).gated_features == 1);
}

// The neighbour gate: a 12 x 12 mm patch of tissue, features 1.5 mm apart,
// stretched by 5% (neighbouring features move apart by less than 0.1 mm).
// Three adjacent features pull 2 mm away from the features around them. The
// scan's prediction is off everywhere by 1.5 mm, which widens the prediction
// gate to 4.5 mm: only the neighbours can tell. The three are left out, with
// a prediction and without one, and no other feature is.
TEST_CASE("constraint mapper: features departing from their neighbours are gated", "[unit]") {
  const int side = 9, n = side * side + 1;
  Eigen::Matrix3Xd X_S(3, n);
  X_S.col(0) = Eigen::Vector3d(0, 0, -0.01);
  for (int a = 1; a < n; ++a) X_S.col(a) = 1.5e-3 * Eigen::Vector3d((a - 1) % side, (a - 1) / side, 0);
  const Scene s = MountAndSurface(X_S);
  ConstraintMapper mapper = TieEveryNode(s);

  const std::vector<int> pulled = {41, 42, 50};  // adjacent, in the middle of the patch
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> noise(-0.1e-3, 0.1e-3);
  Eigen::Matrix3Xd motion(3, n);
  for (int a = 0; a < n; ++a) motion.col(a) = 0.05 * s.X_S.col(a) + Eigen::Vector3d(0.5e-3, 1e-3, 0.3e-3);
  auto frame = [&](double pull_m) {
    std::vector<TrackedPoint> seen;
    for (int a = 1; a < n; ++a) {
      Eigen::Vector3d x = s.X_S.col(a) + motion.col(a) + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      if (std::count(pulled.begin(), pulled.end(), a)) x.z() += pull_m;
      seen.push_back(Feature(a, s, x));
    }
    return seen;
  };
  Eigen::Matrix3Xd predicted = motion;
  predicted.row(1).array() += 1.5e-3;

  REQUIRE(mapper.Process(frame(0), &predicted).gated_features == 0);  // the stretch alone is no outlier
  REQUIRE(mapper.Process(frame(0)).gated_features == 0);
  for (const Eigen::Matrix3Xd* prediction : std::vector<const Eigen::Matrix3Xd*>{&predicted, nullptr}) {
    const NodeTargets targets = mapper.Process(frame(2e-3), prediction);
    REQUIRE(targets.gated_features == 3);
    REQUIRE(targets.nodes.size() == size_t(n - 1 - 3));
    for (int a : pulled) REQUIRE(std::find(targets.nodes.begin(), targets.nodes.end(), a) == targets.nodes.end());
  }
  // A smaller pull, within what neighbouring tissue can differ by, is kept.
  REQUIRE(mapper.Process(frame(0.6e-3), &predicted).gated_features == 0);
}

TEST_CASE("constraint mapper: bad set-up is an error with a reason", "[unit]") {
  const Scene s = MakeScene();
  REQUIRE_THROWS_WITH(ConstraintMapper({3e-3}, s.X_S, Eigen::Matrix3Xd::Zero(3, 2), s.surface, s.fixed, s.T_C_S),
                      Contains("one displacement per mesh node"));
  REQUIRE_THROWS_WITH(ConstraintMapper({3e-3}, s.X_S, s.first_u_S, {0, 1}, s.fixed, s.T_C_S), Contains("no free surface node"));
  REQUIRE_THROWS_WITH(ConstraintMapper({3e-3}, s.X_S, s.first_u_S, {9}, s.fixed, s.T_C_S), Contains("out of range"));
  REQUIRE_THROWS_WITH(ConstraintMapper({-1}, s.X_S, s.first_u_S, s.surface, s.fixed, s.T_C_S), Contains("max_tie_distance_m"));
  REQUIRE_THROWS_WITH(ConstraintMapper({3e-3, 1e-3, 0.5}, s.X_S, s.first_u_S, s.surface, s.fixed, s.T_C_S),
                      Contains("outlier_gate_scale"));
  REQUIRE_THROWS_WITH(ConstraintMapper({3e-3, 1e-3, 3, 0}, s.X_S, s.first_u_S, s.surface, s.fixed, s.T_C_S),
                      Contains("neighbour_radius_m"));
  ConstraintMapper mapper({3e-3}, s.X_S, s.first_u_S, s.surface, s.fixed, s.T_C_S);
  const Eigen::Matrix3Xd too_few = Eigen::Matrix3Xd::Zero(3, 2);
  REQUIRE_THROWS_WITH(mapper.Process({}, &too_few), Contains("prediction has 2 nodes"));
  // Features nowhere near the surface (as with a mesh in the wrong unit): no tie is an error, not a free run.
  const Eigen::Vector3d far_off = s.X_S.col(2) + s.first_u_S.col(2) + Eigen::Vector3d(0, 0, 0.01);
  REQUIRE_THROWS_WITH(mapper.Process({Feature(1, s, far_off)}),
                      Contains("no tracked feature lies within 3 mm of the mesh's free surface (1 features, the "
                               "nearest 10 mm away)"));
}

}  // namespace
}  // namespace dg::stages
