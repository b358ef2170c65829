// Embedded points against independent truths: an affine motion of the nodes
// moves them by that motion exactly; each inside point's element contains it
// by signed sub-volumes; outside points are counted at their true distance.
#include "sim/embedding.h"

#include <array>
#include <cmath>
#include <limits>
#include <random>

#include <Eigen/Dense>
#include <catch2/catch.hpp>

#include "sim/error.h"
#include "tests/sim/box_mesh.h"

namespace dg::sim {
namespace {

const Eigen::Vector3d kSize_m(0.04, 0.03, 0.05);

TetMesh JitteredBox() { return testing::MakeBoxMesh(5, 4, 6, kSize_m, 0.25, 7); }

Eigen::Matrix3Xd PointsInBox(int count, double margin_m, unsigned seed) {
  std::mt19937 rng(seed);
  Eigen::Matrix3Xd points(3, count);
  for (int p = 0; p < count; ++p) {
    for (int i = 0; i < 3; ++i) {
      points(i, p) = std::uniform_real_distribution<double>(-margin_m, kSize_m[i] + margin_m)(rng);
    }
  }
  return points;
}

double DistanceOutsideBox(const Eigen::Vector3d& p) {
  return (p.cwiseMax(Eigen::Vector3d::Zero()).cwiseMin(kSize_m) - p).norm();
}

// Six times the signed volume of (a, b, c, d).
double SixVolume(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
  return (b - a).cross(c - a).dot(d - a);
}

// An affine motion of the nodes moves every embedded point, inside or outside, by the same motion.
TEST_CASE("embedding: affine deformation is reproduced exactly", "[sim][unit]") {
  const TetMesh mesh = JitteredBox();
  const Eigen::Matrix3Xd points = PointsInBox(3000, 0.004, 3);
  const Embedding embedding(mesh, points);
  REQUIRE(embedding.num_points() == 3000);
  REQUIRE(embedding.num_outside() > 100);  // the margin puts some outside: extrapolation is tested too

  Eigen::Matrix3d A;
  A << 1.1, 0.2, -0.05,  //
      -0.1, 0.9, 0.3,    //
      0.05, -0.2, 1.3;
  const Eigen::Vector3d b(0.01, -0.02, 0.005);
  const Eigen::Matrix3Xd nodes = (A * mesh.X_m).colwise() + b;
  const Eigen::Matrix3Xd expected = (A * points).colwise() + b;
  const Eigen::Matrix3Xd rebuilt = embedding.Rebuild(nodes);
  REQUIRE((rebuilt - expected).cwiseAbs().maxCoeff() < 1e-13);  // metres: round-off only
  // The reference nodes give back the reference points.
  REQUIRE((embedding.Rebuild(mesh.X_m) - points).cwiseAbs().maxCoeff() < 1e-13);
}

// Each inside point lies in its element (all four signed sub-volumes non-negative),
// each outside point is counted with its distance to the box.
TEST_CASE("embedding: inside points are found in an element containing them", "[sim][unit]") {
  const TetMesh mesh = JitteredBox();
  const Eigen::Matrix3Xd points = PointsInBox(4000, 0.003, 11);
  const Embedding embedding(mesh, points);
  int outside = 0;
  double farthest = 0;
  for (int p = 0; p < embedding.num_points(); ++p) {
    const Eigen::Vector3d x = points.col(p);
    const double distance = DistanceOutsideBox(x);
    if (distance > 0) {
      ++outside;
      farthest = std::max(farthest, distance);
      continue;
    }
    const int e = embedding.elements()[p];
    std::array<Eigen::Vector3d, 4> corners;
    for (int k = 0; k < 4; ++k) corners[k] = mesh.X_m.col(mesh.tets(k, e));
    const double whole = SixVolume(corners[0], corners[1], corners[2], corners[3]);
    for (int k = 0; k < 4; ++k) {
      std::array<Eigen::Vector3d, 4> sub = corners;
      sub[k] = x;
      const double fraction = SixVolume(sub[0], sub[1], sub[2], sub[3]) / whole;
      REQUIRE(fraction >= -1e-12);
      REQUIRE(fraction == Approx(embedding.weights()(k, p)).margin(1e-12));
    }
  }
  REQUIRE(embedding.num_outside() == outside);
  // The box is meshed exactly (planar faces), so the nearest face's distance is the box distance.
  REQUIRE(embedding.max_outside_distance_m() == Approx(farthest).epsilon(1e-9));
}

TEST_CASE("embedding: bad input is rejected", "[sim][unit]") {
  const TetMesh mesh = JitteredBox();
  Eigen::Matrix3Xd points = PointsInBox(5, 0, 1);
  points(1, 3) = std::numeric_limits<double>::quiet_NaN();
  REQUIRE_THROWS_WITH(Embedding(mesh, points), Catch::Contains("point 3 is not finite"));
  REQUIRE_THROWS_WITH(Embedding(TetMesh{}, PointsInBox(5, 0, 1)), Catch::Contains("no elements"));
}

}  // namespace
}  // namespace dg::sim
