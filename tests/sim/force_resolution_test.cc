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
  // The loads taken off the element forces, node by node in the mesh's order.
  auto taken_off = [&](const ElementLoads<double>& loads) {
    ComputeElementForcesLessLoads(model, u_layout.data(), loads, less.data(), 0, model.num_blocks());
    std::vector<double> difference(applied.size());
    for (int a = 0; a < model.num_nodes(); ++a) {
      double f_plain[3], f_less[3];
      GatherNodalForce(model, plain.data(), model.layout_node(a), f_plain);
      GatherNodalForce(model, less.data(), model.layout_node(a), f_less);
      for (int i = 0; i < 3; ++i) difference[3 * a + i] = f_plain[i] - f_less[i];
    }
    return difference;
  };
  double scale = 0;
  for (double r : applied) scale = std::max(scale, std::abs(r));
  REQUIRE(scale > 0);
  const std::vector<double> one_level = taken_off({weights.data()});
  for (size_t k = 0; k < applied.size(); ++k) {
    REQUIRE_THAT(one_level[k], Catch::Matchers::WithinAbs(applied[k], 1e-12 * scale));
  }

  // Two levels blended 30% of the way: Apply is linear in the weights, so the
  // loads are 0.7 of the first level's plus 0.3 of the second's.
  std::vector<double> second_forces(s.forces.size()), second_weights(weights.size()), second_applied(applied.size());
  for (size_t k = 0; k < second_forces.size(); ++k) second_forces[k] = -0.5 * s.forces[k] + 0.1 * std::cos(double(k));
  resolution.Resolve(s.u_model, second_forces, second_weights);
  resolution.Apply(second_weights, u_current, second_applied);
  const std::vector<double> blended = taken_off({weights.data(), second_weights.data(), 0.3});
  double blended_scale = 0;
  for (size_t k = 0; k < applied.size(); ++k) {
    const double expected = 0.7 * applied[k] + 0.3 * second_applied[k];
    blended_scale = std::max(blended_scale, std::abs(expected));
    REQUIRE_THAT(blended[k], Catch::Matchers::WithinAbs(expected, 1e-12 * scale));
  }
  REQUIRE(blended_scale > 0.1 * scale);
  // A blend of 0 is the first level, bitwise.
  REQUIRE(taken_off({weights.data(), second_weights.data(), 0.0}) == one_level);
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
