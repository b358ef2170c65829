#include "tools/phantom/tube_set.h"

#include <cmath>
#include <numbers>
#include <random>

#include <catch2/catch.hpp>

namespace dg::tools::phantom {
namespace {

double BruteForceDistance(const Eigen::Matrix3Xd& line, const Eigen::Vector3d& X) {
  double best = INFINITY;
  for (int p = 0; p + 1 < line.cols(); ++p) {
    const Eigen::Vector3d a = line.col(p), ab = line.col(p + 1) - a;
    const double t = std::clamp((X - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (a + t * ab - X).norm());
  }
  return best;
}

}  // namespace

// The grid lookup must give what testing every segment gives: points around a
// helix, whose segments cross many cells at every angle.
TEST_CASE("tube set: the same points as the distance to every segment", "[tools][unit]") {
  Eigen::Matrix3Xd helix(3, 300);
  for (int p = 0; p < helix.cols(); ++p) {
    const double angle = 0.05 * p;
    helix.col(p) = Eigen::Vector3d(0.01 * std::cos(angle), 0.01 * std::sin(angle), 0.0001 * p);
  }
  const double radius = 0.0015;
  const TubeSet tubes({helix}, radius);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> xy(-0.013, 0.013), z(-0.003, 0.033);
  int inside = 0, disagreements = 0;
  for (int i = 0; i < 200000; ++i) {
    const Eigen::Vector3d X(xy(rng), xy(rng), z(rng));
    const bool expected = BruteForceDistance(helix, X) <= radius;
    inside += expected;
    disagreements += tubes.Contains(X) != expected;
  }
  CHECK(inside > 5000);  // the sample does cross the tube
  CHECK(disagreements == 0);
}

// A closed ring's tube is a torus: on a 0.1 mm lattice the polyline's tube
// holds the points the torus (sqrt(x^2 + y^2) - R)^2 + z^2 <= r^2 holds.
TEST_CASE("tube set: a ring's tube is a torus", "[tools][unit]") {
  const double R = 0.02, r = 0.001, h = 1e-4;
  Eigen::Matrix3Xd ring(3, 2001);
  for (int p = 0; p < ring.cols(); ++p) {
    const double angle = 2 * std::numbers::pi * p / (ring.cols() - 1);
    ring.col(p) = Eigen::Vector3d(R * std::cos(angle), R * std::sin(angle), 0);
  }
  const TubeSet tubes({ring}, r);
  long in_torus = 0, disagreements = 0;
  const int n_xy = int(std::ceil((R + r) / h)), n_z = int(std::ceil(r / h));
  for (int k = -n_z; k <= n_z; ++k)
    for (int j = -n_xy; j <= n_xy; ++j)
      for (int i = -n_xy; i <= n_xy; ++i) {
        const Eigen::Vector3d X = h * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5);
        const bool torus = std::pow(X.head<2>().norm() - R, 2) + X.z() * X.z() <= r * r;
        in_torus += torus;
        disagreements += tubes.Contains(X) != torus;
      }
  INFO(disagreements << " of " << in_torus << " lattice points in the torus disagree");
  CHECK(in_torus > 390000);  // 2 pi^2 R r^2 / h^3 = 394,784
  // Chords sit inside the circle by at most R (1 - cos(pi / 2000)) = 25 nm: only
  // points that close to the surface could differ.
  CHECK(disagreements <= 4);
}

}  // namespace dg::tools::phantom
