#include "sim/force_resolution.h"

#include <random>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>

#include "sim/error.h"
#include "sim/tled_kernel.h"
#include "tests/sim/box_mesh.h"

namespace dg::sim {
namespace {

using Catch::Matchers::Contains;
using testing::MakeBoxMesh;

struct Setup {
  std::shared_ptr<const TledModel<double>> model;
  std::vector<double> u_model, forces;
};

// An irregular box in a smoothly deformed geometry, with random nodal forces.
Setup MakeSetup() {
  Setup s;
  s.model = std::make_shared<const TledModel<double>>(MakeBoxMesh(3, 3, 3, {0.02, 0.02, 0.02}, 0.2), Material{});
  const TetMesh& mesh = s.model->mesh();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1, 1);
  for (int a = 0; a < mesh.num_nodes(); ++a) {
    const Eigen::Vector3d X = mesh.X_m.col(a);
    const Eigen::Vector3d u(0.1 * X.y() * X.z() / 0.02, -0.08 * X.x(), 0.05 * X.z() * X.x() / 0.02);
    for (int i = 0; i < 3; ++i) {
      s.u_model.push_back(u[i]);
      s.forces.push_back(1e-3 * unit(rng));
    }
  }
  return s;
}

// Eq. 5 is exact: the weights, applied to the geometry they were computed in,
// give back every node's recovered force (sum over its n_a elements of r / n_a).
TEST_CASE("force resolution: weights reconstruct the force in the original geometry", "[unit]") {
  const Setup s = MakeSetup();
  ForceResolution<double> resolution(s.model);
  std::vector<double> weights(resolution.weights_size()), applied(s.forces.size());
  resolution.Resolve(s.u_model, s.forces, weights);
  resolution.Apply(weights, s.u_model, applied);
  for (size_t i = 0; i < applied.size(); ++i) REQUIRE_THAT(applied[i], Catch::Matchers::WithinAbs(s.forces[i], 1e-15));
}

// Objectivity: a rigid rotation (and translation) of the current geometry
// rotates every applied force with it, r' = Q r.
TEST_CASE("force resolution: applied forces rotate with a rigidly rotated geometry", "[unit]") {
  const Setup s = MakeSetup();
  ForceResolution<double> resolution(s.model);
  std::vector<double> weights(resolution.weights_size()), applied(s.forces.size());
  resolution.Resolve(s.u_model, s.forces, weights);
  const Eigen::Matrix3d Q = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, -1).normalized()).toRotationMatrix();
  const Eigen::Vector3d shift(0.003, -0.01, 0.02);
  const TetMesh& mesh = s.model->mesh();
  std::vector<double> u_rotated(s.u_model.size());
  for (int a = 0; a < mesh.num_nodes(); ++a) {
    const Eigen::Vector3d x = mesh.X_m.col(a) + Eigen::Vector3d::Map(&s.u_model[3 * a]);
    Eigen::Vector3d::Map(&u_rotated[3 * a]) = Q * x + shift - mesh.X_m.col(a);
  }
  resolution.Apply(weights, u_rotated, applied);
  for (int a = 0; a < mesh.num_nodes(); ++a) {
    const Eigen::Vector3d expected = Q * Eigen::Vector3d::Map(&s.forces[3 * a]);
    REQUIRE((Eigen::Vector3d::Map(&applied[3 * a]) - expected).norm() <= 1e-14);
  }
}

// The solver applies the weights inside its element pass
// (ComputeElementForcesLessLoads): its nodal sums are the internal forces less
// what Apply() gives, in a geometry other than the one resolved in.
TEST_CASE("force resolution: loads taken off in the element pass equal Apply's forces", "[unit]") {
  const Setup s = MakeSetup();
  const TledModel<double>& model = *s.model;
  ForceResolution<double> resolution(s.model);
  std::vector<double> weights(resolution.weights_size()), applied(s.forces.size());
  resolution.Resolve(s.u_model, s.forces, weights);
  std::vector<double> u_current(s.u_model.size());
  for (size_t i = 0; i < u_current.size(); ++i) u_current[i] = 0.7 * s.u_model[i] + 1e-4 * std::sin(double(i));
  resolution.Apply(weights, u_current, applied);
  // The kernels work in the model's layout order.
  std::vector<double> u_layout(u_current.size());
  model.ToLayout(std::span<const double>(u_current), std::span<double>(u_layout));
  AlignedVector<double> plain(model.force_array_size()), less(model.force_array_size());
  ComputeElementForces(model, u_layout.data(), plain.data(), 0, model.num_blocks());
  ComputeElementForcesLessLoads(model, u_layout.data(), weights.data(), less.data(), 0, model.num_blocks());
  double scale = 0;
  for (double r : applied) scale = std::max(scale, std::abs(r));
  REQUIRE(scale > 0);
  for (int a = 0; a < model.num_nodes(); ++a) {
    double f_plain[3], f_less[3];
    const int l = model.layout_node(a);
    GatherNodalForce(model, plain.data(), l, f_plain);
    GatherNodalForce(model, less.data(), l, f_less);
    for (int i = 0; i < 3; ++i) REQUIRE_THAT(f_plain[i] - f_less[i], Catch::Matchers::WithinAbs(applied[3 * a + i], 1e-12 * scale));
  }
}

// A geometry that squashes an element flat cannot carry weights: a dg::Error
// names the element instead of NaN forces later.
TEST_CASE("force resolution: a degenerate edge triple is an error naming the element", "[unit]") {
  Setup s = MakeSetup();
  ForceResolution<double> resolution(s.model);
  const TetMesh& mesh = s.model->mesh();
  // Flatten the whole box onto z = 0: every element's volume vanishes.
  for (int a = 0; a < mesh.num_nodes(); ++a) s.u_model[3 * a + 2] = -mesh.X_m(2, a);
  std::vector<double> weights(resolution.weights_size());
  REQUIRE_THROWS_WITH(resolution.Resolve(s.u_model, s.forces, weights), Contains("degenerate edge triple") && Contains("element"));
  REQUIRE_THROWS_WITH(resolution.CheckGeometry(s.u_model, "phase 0.5"), Contains("phase 0.5"));
}

}  // namespace
}  // namespace dg::sim
