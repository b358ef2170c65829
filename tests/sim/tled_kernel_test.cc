#include "sim/tled_kernel.h"

#include <cmath>
#include <random>

#include <Eigen/Dense>
#include <catch2/catch.hpp>

#include "sim/corner_loads.h"
#include "sim/tled_model.h"
#include "tests/sim/box_mesh.h"

namespace dg::sim {
namespace {

using testing::MakeBoxMesh;

// The kernel's nodal forces at u_m, both in the mesh's node order (the
// kernel works in the model's layout order).
template <typename T>
Eigen::VectorXd NodalForces(const TledModel<T>& model, const Eigen::VectorXd& u_m) {
  const size_t n = u_m.size();
  std::vector<T> u(n), f_layout(n);
  model.ToLayout(std::span<const double>(u_m.data(), n), std::span<T>(u));
  AlignedVector<T> forces(model.force_array_size());
  ComputeElementForces(model, u.data(), forces.data(), 0, model.num_blocks());
  for (int a = 0; a < model.num_nodes(); ++a) GatherNodalForce(model, forces.data(), a, &f_layout[3 * a]);
  Eigen::VectorXd f(n);
  model.ToMeshOrder(std::span<const T>(f_layout), std::span<double>(f.data(), n));
  return f;
}

// Strain energy of the whole mesh, written independently of the kernel from
// W = mu/2 (J^(-2/3) tr C - 3) + kappa/2 (J - 1)^2.
double StrainEnergy(const TetMesh& mesh, const Material& material, const Eigen::VectorXd& u_m) {
  const double mu = material.shear_modulus_pa(), kappa = material.bulk_modulus_pa();
  double energy = 0;
  for (int e = 0; e < mesh.num_tets(); ++e) {
    Eigen::Matrix3d reference, current;
    for (int c = 0; c < 3; ++c) {
      const int n0 = mesh.tets(0, e), nc = mesh.tets(c + 1, e);
      reference.col(c) = mesh.X_m.col(nc) - mesh.X_m.col(n0);
      current.col(c) = reference.col(c) + u_m.segment<3>(3 * nc) - u_m.segment<3>(3 * n0);
    }
    const Eigen::Matrix3d F = current * reference.inverse();
    const double J = F.determinant();
    const double W = mu / 2 * (std::pow(J, -2.0 / 3.0) * (F.transpose() * F).trace() - 3) +
                     kappa / 2 * (J - 1) * (J - 1);
    energy += reference.determinant() / 6.0 * W;
  }
  return energy;
}

Eigen::VectorXd AffineDisplacement(const TetMesh& mesh, const Eigen::Matrix3d& A, const Eigen::Vector3d& b) {
  Eigen::VectorXd u(3 * mesh.num_nodes());
  for (int a = 0; a < mesh.num_nodes(); ++a) u.segment<3>(3 * a) = A * mesh.X_m.col(a) + b;
  return u;
}

}  // namespace

// The bit-level guess plus Newton steps agrees with pow(x, -1/3) to round-off.
TEST_CASE("tled kernel: inverse cube root matches std::pow", "[sim][unit]") {
  for (double x = 1e-12; x < 1e12; x *= 1.37) {
    const double truth = std::pow(x, -1.0 / 3.0);
    REQUIRE(InverseCubeRoot(x) == Approx(truth).epsilon(1e-15));  // 4.5 ulp: the last Newton step rounds
    REQUIRE(InverseCubeRoot(static_cast<float>(x)) == Approx(truth).epsilon(3e-7));
  }
}

// A homogeneous (affine) finite deformation of an irregular mesh leaves interior
// nodes force-free (patch test); boundary nodes carry the traction.
TEMPLATE_TEST_CASE("tled kernel: patch test on an irregular mesh", "[sim][unit]", float, double) {
  const TetMesh mesh = MakeBoxMesh(6, 5, 4, {0.05, 0.04, 0.03}, 0.3);
  const TledModel<TestType> model(mesh, Material{});
  Eigen::Matrix3d A;
  A << 0.10, 0.05, -0.02,  //
      0.03, -0.08, 0.04,   //
      -0.01, 0.02, 0.15;
  const Eigen::VectorXd f = NodalForces(model, AffineDisplacement(mesh, A, {1e-3, -2e-3, 5e-4}));
  const std::vector<int> boundary = BoundaryNodes(mesh);
  double boundary_max = 0, interior_max = 0;
  for (int a = 0; a < mesh.num_nodes(); ++a) {
    const double norm = f.segment<3>(3 * a).norm();
    if (std::binary_search(boundary.begin(), boundary.end(), a)) {
      boundary_max = std::max(boundary_max, norm);
    } else {
      interior_max = std::max(interior_max, norm);
    }
  }
  REQUIRE(boundary_max > 0);
  const double round_off = std::is_same_v<TestType, float> ? 1e-5 : 1e-12;
  REQUIRE(interior_max / boundary_max < round_off);
}

// The kernel's nodal forces are the gradient of the neo-Hookean strain energy,
// checked by central differences of an independent energy evaluation.
TEST_CASE("tled kernel: forces are the strain energy gradient", "[sim][unit]") {
  const TetMesh mesh = MakeBoxMesh(3, 2, 2, {0.03, 0.02, 0.02}, 0.25);
  const Material material{5e3, 0.45, 1e3};
  const TledModel<double> model(mesh, material);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-1.5e-3, 1.5e-3);  // up to ~15% strain
  Eigen::VectorXd u(3 * mesh.num_nodes());
  for (int i = 0; i < u.size(); ++i) u[i] = uniform(rng);
  const Eigen::VectorXd f = NodalForces(model, u);
  const double h = 1e-8;
  for (int dof = 0; dof < u.size(); ++dof) {
    Eigen::VectorXd plus = u, minus = u;
    plus[dof] += h;
    minus[dof] -= h;
    const double gradient = (StrainEnergy(mesh, material, plus) - StrainEnergy(mesh, material, minus)) / (2 * h);
    REQUIRE(f[dof] == Approx(gradient).epsilon(1e-5).margin(1e-6 * f.cwiseAbs().maxCoeff()));
  }
}

// A rigid rotation and translation produces no internal force (objectivity),
// however large the rotation.
TEST_CASE("tled kernel: rigid motion is force-free", "[sim][unit]") {
  const TetMesh mesh = MakeBoxMesh(4, 4, 4, {0.04, 0.04, 0.04}, 0.3);
  const TledModel<double> model(mesh, Material{});
  const Eigen::Matrix3d R = Eigen::AngleAxisd(1.2, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::VectorXd f = NodalForces(model, AffineDisplacement(mesh, R - Eigen::Matrix3d::Identity(), {0.01, 0, 0}));
  // Force scale of a 1% strain on these elements: E * 0.01 * (1 cm)^2.
  REQUIRE(f.cwiseAbs().maxCoeff() < 1e-10 * 3e3 * 0.01 * 1e-4);
}

// Single precision agrees with double on a large deformation to float accuracy.
TEST_CASE("tled kernel: float forces agree with double", "[sim][unit]") {
  const TetMesh mesh = MakeBoxMesh(5, 5, 5, {0.05, 0.05, 0.05}, 0.3);
  const Material material{};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uniform(-1e-3, 1e-3);
  Eigen::VectorXd u(3 * mesh.num_nodes());
  for (int i = 0; i < u.size(); ++i) u[i] = uniform(rng);
  const Eigen::VectorXd f_double = NodalForces(TledModel<double>(mesh, material), u);
  const Eigen::VectorXd f_float = NodalForces(TledModel<float>(mesh, material), u);
  REQUIRE((f_float - f_double).cwiseAbs().maxCoeff() < 1e-4 * f_double.cwiseAbs().maxCoeff());
}

// The element pass's block-wide loads of corner displacements are the nodes'
// values, bitwise, in every block (the last node's included, whose three
// values end the array).
TEST_CASE("tled kernel: corner displacements loaded a block at a time are the nodes'", "[sim][unit]") {
  if constexpr (!kCornerLoadsTransposed) {
    WARN("not checked: this build's target has no AVX-512, and the element pass loads corners lane by lane");
  } else {
    const TetMesh mesh = MakeBoxMesh(6, 5, 4, {0.05, 0.04, 0.03}, 0.3);
    const TledModel<float> model(mesh, Material{});
    constexpr int W = TledModel<float>::kLanes;
    std::vector<float> u(3 * model.num_nodes());
    std::mt19937 rng(5);
    for (float& value : u) value = std::uniform_real_distribution<float>(-1, 1)(rng);
    bool last_node_read = false;
    for (int b = 0; b < model.num_blocks(); ++b) {
      alignas(64) float corners[12 * W];
      LoadCornerDisplacements(model.block_nodes(b), u.data(), corners);
      for (int c = 0; c < 4; ++c) {
        for (int l = 0; l < W; ++l) {
          const int node = model.block_nodes(b)[c * W + l];
          last_node_read |= node == model.num_nodes() - 1;
          for (int axis = 0; axis < 3; ++axis) REQUIRE(corners[(3 * c + axis) * W + l] == u[3 * node + axis]);
        }
      }
    }
    REQUIRE(last_node_read);
  }
}

// Lumped masses add up to rho times the volume.
TEST_CASE("tled model: lumped mass is the body's mass", "[sim][unit]") {
  const TetMesh mesh = MakeBoxMesh(4, 3, 2, {0.04, 0.03, 0.02}, 0.2);
  const TledModel<float> model(mesh, Material{3e3, 0.45, 1060});
  double total = 0;
  for (double m : model.lumped_mass_kg()) total += m;
  REQUIRE(total == Approx(1060 * 0.04 * 0.03 * 0.02).epsilon(1e-12));
}

}  // namespace dg::sim
