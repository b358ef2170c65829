#include "sim/tled_solver.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <random>

#include <Eigen/Dense>
#include <catch2/catch.hpp>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include "sim/error.h"
#include "tests/sim/box_mesh.h"

namespace dg::sim {
namespace {

using testing::MakeBoxMesh;

std::vector<int> Dofs(const std::vector<int>& nodes, int axis) {
  std::vector<int> dofs;
  for (int a : nodes) dofs.push_back(3 * a + axis);
  return dofs;
}

// Uniaxial stress with rollers: the bottom slides on z = 0, the top face is
// moved in z and free laterally, two corner dofs stop rigid motion.
struct UniaxialProblem {
  TetMesh mesh;
  BoundaryConditions conditions;
  double area_m2;
  double height_m;
};

UniaxialProblem MakeUniaxial() {
  UniaxialProblem p;
  const double L = 0.01;
  p.mesh = MakeBoxMesh(4, 4, 4, {L, L, L}, 0.25);
  p.area_m2 = L * L;
  p.height_m = L;
  p.conditions.fixed_dofs = Dofs(p.mesh.node_sets.at("zmin"), 2);
  const std::vector<int> origin = NodesInBox(p.mesh, {0, 0, 0}, {0, 0, 0}, 1e-9);
  const std::vector<int> x_corner = NodesInBox(p.mesh, {L, 0, 0}, {L, 0, 0}, 1e-9);
  p.conditions.fixed_dofs.push_back(3 * origin[0]);
  p.conditions.fixed_dofs.push_back(3 * origin[0] + 1);
  p.conditions.fixed_dofs.push_back(3 * x_corner[0] + 1);
  p.conditions.prescribed_dofs = Dofs(p.mesh.node_sets.at("zmax"), 2);
  return p;
}

// Relaxes the uniaxial problem to equilibrium at axial stretch `stretch` and
// returns the nominal stress: the top face's total z reaction over the reference area.
double RelaxedNominalStress(const Material& material, double stretch) {
  const UniaxialProblem p = MakeUniaxial();
  auto model = std::make_shared<const TledModel<double>>(p.mesh, material);
  SolverOptions options;
  // Near-critical damping of the slowest mode relaxes in tens of milliseconds.
  options.damping_per_s = 400;
  const StabilityReport stability = EstimateStability(p.mesh, material, p.conditions.fixed_dofs);
  options.dt_s = 0.4 * stability.dt_critical_s;
  TledSolver<double> solver(model, p.conditions, options);
  const std::vector<double> target(p.conditions.prescribed_dofs.size(), (stretch - 1) * p.height_m);
  solver.Advance(static_cast<int>(0.05 / options.dt_s), target);
  solver.Advance(static_cast<int>(0.15 / options.dt_s), target);
  double reaction = 0;
  for (int dof : p.conditions.prescribed_dofs) reaction += solver.reaction_forces()[dof];
  return reaction / p.area_m2;
}

// Analytic nominal stress P_zz of the neo-Hookean solid in uniaxial stress,
// F = diag(a, a, b): a solves S_xx(a) = 0 (free lateral faces), by bisection.
double AnalyticNominalStress(const Material& material, double b) {
  const double mu = material.shear_modulus_pa(), kappa = material.bulk_modulus_pa();
  auto S = [&](double a, double stretch_sq) {
    const double J = a * a * b, I1 = 2 * a * a + b * b;
    return mu * std::pow(J, -2.0 / 3.0) * (1 - I1 / (3 * stretch_sq)) + kappa * J * (J - 1) / stretch_sq;
  };
  double lo = 0.5, hi = 2.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (S(mid, mid * mid) > 0 ? hi : lo) = mid;
  }
  const double a = 0.5 * (lo + hi);
  return b * S(a, b * b);
}

}  // namespace

// At 1e-4 strain the reaction is linear elasticity's E * strain * area.
TEST_CASE("tled solver: small-strain limit is linear elasticity", "[sim][unit]") {
  const Material material{};
  const double strain = 1e-4;
  REQUIRE(RelaxedNominalStress(material, 1 - strain) ==
          Approx(-material.youngs_modulus_pa * strain).epsilon(0.005));
}

// Relaxed uniaxial stretch and compression match the analytic neo-Hookean stress.
TEST_CASE("tled solver: uniaxial stress matches neo-Hookean analytic value", "[sim][unit]") {
  const Material material{};
  for (double stretch : {0.9, 0.7, 1.1}) {
    INFO("stretch " << stretch);
    REQUIRE(RelaxedNominalStress(material, stretch) == Approx(AnalyticNominalStress(material, stretch)).epsilon(0.01));
  }
}

// A fixed-free bar released from a uniform axial stretch vibrates at the first
// axial frequency c / (4 L), c = sqrt(E / rho) (nu = 0: no lateral coupling).
TEST_CASE("tled solver: fixed-free bar's first axial frequency", "[sim][unit]") {
  const double L = 0.1;
  TetMesh mesh = MakeBoxMesh(24, 2, 2, {L, 0.01, 0.01}, 0.2);
  const Material material{3e3, 0.0, 1e3};
  BoundaryConditions conditions;
  for (int axis = 0; axis < 3; ++axis) {
    for (int dof : Dofs(mesh.node_sets.at("xmin"), axis)) conditions.fixed_dofs.push_back(dof);
  }
  SolverOptions options;
  options.damping_per_s = 0;
  TledSolver<double> solver(std::make_shared<const TledModel<double>>(mesh, material), conditions, options);
  const double strain = 1e-4;
  std::vector<double> u(3 * mesh.num_nodes(), 0.0), v(u.size(), 0.0);
  for (int a = 0; a < mesh.num_nodes(); ++a) u[3 * a] = strain * mesh.X_m(0, a);
  solver.SetState(u, v);

  // Zero crossings of the tip's mean axial displacement; at the first mode's
  // crossings every other (odd) mode crosses too, so the spacing is exact.
  const std::vector<int>& tip = mesh.node_sets.at("xmax");
  auto tip_u = [&] {
    double sum = 0;
    for (int a : tip) sum += solver.displacement()[3 * a];
    return sum / tip.size();
  };
  std::vector<double> crossings;
  double previous = tip_u(), previous_t = 0;
  while (crossings.size() < 7) {
    solver.Advance(1, {});
    const double now = tip_u();
    if ((previous > 0) != (now > 0)) {
      crossings.push_back(previous_t + options.dt_s * previous / (previous - now));
    }
    previous = now;
    previous_t = solver.time_s();
    REQUIRE(solver.time_s() < 2.0);
  }
  const double period = 2 * (crossings.back() - crossings.front()) / (crossings.size() - 1);
  const double analytic = 4 * L / std::sqrt(material.youngs_modulus_pa / material.density_kg_m3);
  REQUIRE(period == Approx(analytic).epsilon(0.03));
}

// The Lanczos estimate equals the largest eigenvalue of M^-1 K from a dense
// solve with an independently assembled linear-elastic stiffness, and the
// per-element bound is the more conservative of the two.
TEST_CASE("stability: Lanczos omega_max matches a dense eigensolve", "[sim][unit]") {
  const TetMesh mesh = MakeBoxMesh(3, 2, 2, {0.03, 0.02, 0.02}, 0.25);
  const Material material{1e4, 0.45, 1e3};
  const std::vector<int> fixed = Dofs(mesh.node_sets.at("zmin"), 2);
  const StabilityReport report = EstimateStability(mesh, material, fixed);

  const int n = 3 * mesh.num_nodes();
  const double lambda = material.lame_lambda_pa(), mu = material.shear_modulus_pa();
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd mass = Eigen::VectorXd::Zero(n);
  for (int e = 0; e < mesh.num_tets(); ++e) {
    Eigen::Matrix3d edges;
    for (int c = 0; c < 3; ++c) edges.col(c) = mesh.X_m.col(mesh.tets(c + 1, e)) - mesh.X_m.col(mesh.tets(0, e));
    const double volume = edges.determinant() / 6;
    Eigen::Matrix<double, 4, 3> G;  // rows: dN_a/dX
    G.bottomRows<3>() = edges.inverse();
    G.row(0) = -G.bottomRows<3>().colwise().sum();
    for (int a = 0; a < 4; ++a) {
      for (int b = 0; b < 4; ++b) {
        // Linear elasticity: K_ab = V (lambda g_a g_b^T + mu g_b g_a^T + mu (g_a . g_b) I).
        const Eigen::Vector3d ga = G.row(a), gb = G.row(b);
        const Eigen::Matrix3d Kab =
            volume * (lambda * ga * gb.transpose() + mu * gb * ga.transpose() + mu * ga.dot(gb) * Eigen::Matrix3d::Identity());
        K.block<3, 3>(3 * mesh.tets(a, e), 3 * mesh.tets(b, e)) += Kab;
      }
      mass.segment<3>(3 * mesh.tets(a, e)).array() += material.density_kg_m3 * volume / 4;
    }
  }
  std::vector<int> free;
  for (int i = 0; i < n; ++i) {
    if (std::find(fixed.begin(), fixed.end(), i) == fixed.end()) free.push_back(i);
  }
  Eigen::MatrixXd A(free.size(), free.size());
  for (size_t i = 0; i < free.size(); ++i) {
    for (size_t j = 0; j < free.size(); ++j) {
      A(i, j) = K(free[i], free[j]) / std::sqrt(mass[free[i]] * mass[free[j]]);
    }
  }
  const double omega_max = std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(A).eigenvalues().maxCoeff());
  REQUIRE(report.omega_max_rad_s == Approx(omega_max).epsilon(1e-5));
  REQUIRE(report.dt_element_bound_s < report.dt_critical_s);
}

namespace {

// A stiff, nearly incompressible cube on a fixed base, set moving by a tiny
// seeded random velocity that excites every mode, run undamped.
struct StiffCube {
  TetMesh mesh = MakeBoxMesh(3, 3, 3, {0.01, 0.01, 0.01}, 0.2);
  Material material{1e6, 0.499, 1e3};
  BoundaryConditions conditions;
  StabilityReport stability;
  StiffCube() {
    for (int axis = 0; axis < 3; ++axis) {
      for (int dof : Dofs(mesh.node_sets.at("zmin"), axis)) conditions.fixed_dofs.push_back(dof);
    }
    stability = EstimateStability(mesh, material, conditions.fixed_dofs);
  }
  TledSolver<double> Solver(double dt_fraction, TimeStepPolicy policy) const {
    SolverOptions options;
    options.damping_per_s = 0;
    options.dt_s = dt_fraction * stability.dt_critical_s;
    options.time_step_policy = policy;
    TledSolver<double> solver(std::make_shared<const TledModel<double>>(mesh, material), conditions, options,
                              &stability);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> uniform(-1e-6, 1e-6);
    std::vector<double> u(3 * mesh.num_nodes(), 0.0), v(u.size());
    for (double& vi : v) vi = uniform(rng);
    for (int dof : conditions.fixed_dofs) v[dof] = 0;
    solver.SetState(u, v);
    return solver;
  }
};

}  // namespace

// Above the estimated limit the undamped scheme blows up, and it is caught as such.
TEST_CASE("stability: stiff material at 1.1 dt_cr blows up and is reported", "[sim][unit]") {
  StiffCube cube;
  TledSolver<double> solver = cube.Solver(1.1, TimeStepPolicy::kUnchecked);
  REQUIRE_THROWS_WITH(solver.Advance(10000, {}), Catch::Contains("blow-up") && Catch::Contains("node"));
  REQUIRE(solver.steps_taken() < 1000);
}

// Below it the same run stays bounded over 10^4 steps: kinetic energy never
// exceeds a few times its start (energy only moves between kinetic and strain).
TEST_CASE("stability: stiff material at 0.9 dt_cr stays bounded", "[sim][unit]") {
  StiffCube cube;
  TledSolver<double> solver = cube.Solver(0.9, TimeStepPolicy::kUnchecked);
  solver.Advance(1, {});
  const double initial = solver.kinetic_energy_j();
  double largest = 0;
  for (int i = 0; i < 10000; ++i) {
    solver.Advance(1, {});
    largest = std::max(largest, solver.kinetic_energy_j());
  }
  REQUIRE(std::isfinite(largest));
  REQUIRE(largest < 10 * initial);
}

// With the guard on, a step above the limit is refused with both estimates named;
// with substepping it runs the fewest safe substeps.
TEST_CASE("stability: guard refuses or substeps an unstable step", "[sim][unit]") {
  StiffCube cube;
  REQUIRE_THROWS_WITH(cube.Solver(1.1, TimeStepPolicy::kRefuse),
                      Catch::Contains("critical time step") && Catch::Contains("per-element bound"));
  // nu = 0.499: the default safety is 0.65 of dt_cr, so 2.5 dt_cr takes ceil(2.5 / 0.65) = 4 substeps.
  TledSolver<double> substepped = cube.Solver(2.5, TimeStepPolicy::kSubstep);
  REQUIRE(substepped.stability_safety() == Approx(0.65));
  REQUIRE(substepped.substeps_per_step() == 4);
  REQUIRE_NOTHROW(substepped.Advance(1000, {}));
  // Unchecked above the limit, the divergence is blamed on the step, whichever detector sees it first.
  TledSolver<double> unchecked = cube.Solver(3.0, TimeStepPolicy::kUnchecked);
  REQUIRE_THROWS_WITH(unchecked.Advance(1000, {}), Catch::Contains("reduce dt below"));
}

// The default safety against the stability study's findings: every cell ran
// below 0.9 dt_cr for nu <= 0.45; at nu = 0.49 one in 40 failed at 0.82; at
// nu = 0.499 all failed from 0.7 and all ran below it.
TEST_CASE("stability: the default safety fraction follows Poisson's ratio", "[sim][unit]") {
  REQUIRE(DefaultStabilitySafety(0.3) == 0.9);
  REQUIRE(DefaultStabilitySafety(0.45) == Approx(0.9));
  REQUIRE(DefaultStabilitySafety(0.49) == Approx(0.797).margin(1e-3));
  REQUIRE(DefaultStabilitySafety(0.499) == Approx(0.65));
  REQUIRE(DefaultStabilitySafety(0.4999) == 0.65);
  REQUIRE(DefaultStabilitySafety(0.5) == 0.65);
}

// Driving one node through its element's opposite face is reported as an
// inversion of that element, with the step.
TEST_CASE("tled solver: crushed element gives the inversion error", "[sim][unit]") {
  const TetMesh mesh = MakeBoxMesh(2, 2, 2, {0.01, 0.01, 0.01}, 0.0);
  const int e = 5;
  BoundaryConditions conditions;
  std::vector<double> target;
  const Eigen::Vector3d face_centre =
      (mesh.X_m.col(mesh.tets(1, e)) + mesh.X_m.col(mesh.tets(2, e)) + mesh.X_m.col(mesh.tets(3, e))) / 3;
  const Eigen::Vector3d through = 2 * (face_centre - mesh.X_m.col(mesh.tets(0, e)));
  for (int c = 0; c < 4; ++c) {
    for (int axis = 0; axis < 3; ++axis) {
      conditions.prescribed_dofs.push_back(3 * mesh.tets(c, e) + axis);
      target.push_back(c == 0 ? through[axis] : 0.0);
    }
  }
  TledSolver<double> solver(std::make_shared<const TledModel<double>>(mesh, Material{}), conditions, SolverOptions{});
  REQUIRE_THROWS_WITH(solver.Advance(20, target), Catch::Contains("inverted element") &&
                                                      Catch::Contains("element " + std::to_string(e)) &&
                                                      Catch::Contains("t = "));
}

// An inversion found on two threads leaves the state of the last completed
// step, as on one: the same step count and bitwise the same displacements,
// internal forces and reactions (no worker has gone on into the next step).
TEST_CASE("tled solver: after an inversion the state is the last completed step's on any thread count",
          "[sim][unit]") {
  const TetMesh mesh = MakeBoxMesh(10, 8, 6, {0.05, 0.04, 0.03}, 0.3);
  BoundaryConditions conditions;
  conditions.fixed_dofs = Dofs(mesh.node_sets.at("zmin"), 2);
  // One node of the top face driven down through the box.
  const int node = mesh.node_sets.at("zmax")[mesh.node_sets.at("zmax").size() / 2];
  conditions.prescribed_dofs = {3 * node + 2};
  struct State {
    long long steps;
    std::vector<float> u, u_before, internal, reaction;
  };
  auto run = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    SolverOptions options;
    options.threads = threads;
    TledSolver<float> solver(std::make_shared<const TledModel<float>>(mesh, Material{}, threads), conditions, options);
    REQUIRE(solver.model().parts() == threads);
    REQUIRE_THROWS_WITH(solver.Advance(400, std::vector<double>{-0.04}), Catch::Contains("inverted element"));
    auto copy = [](std::span<const float> values) { return std::vector<float>(values.begin(), values.end()); };
    return State{solver.steps_taken(), copy(solver.displacement()), copy(solver.previous_displacement()),
                 copy(solver.internal_forces()), copy(solver.reaction_forces())};
  };
  const State one = run(1), two = run(2);
  REQUIRE(one.steps > 1);
  CHECK(two.steps == one.steps);
  CHECK(two.u == one.u);
  CHECK(two.u_before == one.u_before);
  CHECK(two.internal == one.internal);
  CHECK(two.reaction == one.reaction);
}

// NaN in a prescribed target or a load is refused before it enters the state.
TEST_CASE("tled solver: non-finite input is refused", "[sim][unit]") {
  const TetMesh mesh = MakeBoxMesh(2, 2, 2, {0.01, 0.01, 0.01});
  BoundaryConditions conditions;
  conditions.prescribed_dofs = {2};
  TledSolver<float> solver(std::make_shared<const TledModel<float>>(mesh, Material{}), conditions, SolverOptions{});
  const std::vector<double> nan_target{std::nan("")};
  REQUIRE_THROWS_WITH(solver.Advance(1, nan_target), Catch::Contains("not finite"));
  std::vector<double> forces(3 * mesh.num_nodes(), 0.0);
  forces[7] = std::numeric_limits<double>::infinity();
  REQUIRE_THROWS_WITH(solver.SetExternalForces(forces), Catch::Contains("not finite") && Catch::Contains("node 2"));
  REQUIRE_THROWS_WITH(TledModel<float>(mesh, Material{std::nan(""), 0.45, 1e3}), Catch::Contains("Young"));
}

// The result is bitwise the same on one thread and on two, also with a model
// of fewer parts than workers (whose node chunks wait for every element chunk).
TEST_CASE("tled solver: thread count does not change the result", "[sim][unit]") {
  const TetMesh mesh = MakeBoxMesh(10, 8, 6, {0.05, 0.04, 0.03}, 0.3);
  BoundaryConditions conditions;
  conditions.fixed_dofs = Dofs(mesh.node_sets.at("zmin"), 2);
  conditions.prescribed_dofs = Dofs(mesh.node_sets.at("zmax"), 2);
  auto run = [&](int threads, int parts, bool helper_joins = true) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    SolverOptions options;
    options.gravity_m_s2 = {0, 0, -9.81};
    options.threads = threads;
    // A helper whose work never starts: the caller steps every part.
    if (!helper_joins) options.launch_helper = [](std::function<void()>) {};
    TledSolver<float> solver(std::make_shared<const TledModel<float>>(mesh, Material{}, parts), conditions, options);
    REQUIRE(solver.threads() == threads);
    REQUIRE(solver.model().parts() == parts);
    solver.Advance(300, std::vector<double>(conditions.prescribed_dofs.size(), -2e-3));
    std::vector<float> state(solver.displacement().begin(), solver.displacement().end());
    state.insert(state.end(), solver.reaction_forces().begin(), solver.reaction_forces().end());
    return state;
  };
  // A model of one part has no cut to copy across: the truth for two parts,
  // stepped by one thread or two. Two threads on a model of two parts run
  // free between barriers (docs/solver.md, "Free-running steps").
  const std::vector<float> one_thread = run(1, 1);
  REQUIRE(run(2, 2) == one_thread);
  REQUIRE(run(2, 2, /*helper_joins=*/false) == one_thread);
  REQUIRE(run(1, 2) == one_thread);
  REQUIRE(run(2, 1) == one_thread);
}

// The model numbers nodes its own way (layout order) whatever order the mesh
// gives them in, and every input and output stays in the mesh's order: the
// same mesh with its nodes shuffled, as a file may list them, gives the same
// displacements and reactions, node for node, bitwise.
TEST_CASE("tled solver: node order of the mesh does not change the result", "[sim][unit]") {
  const TetMesh mesh = MakeBoxMesh(10, 8, 6, {0.05, 0.04, 0.03}, 0.3);
  std::vector<int> shuffled_id(mesh.num_nodes());  // shuffled_id[node of mesh]
  std::iota(shuffled_id.begin(), shuffled_id.end(), 0);
  std::shuffle(shuffled_id.begin(), shuffled_id.end(), std::mt19937(7));
  TetMesh shuffled = mesh;
  for (int a = 0; a < mesh.num_nodes(); ++a) shuffled.X_m.col(shuffled_id[a]) = mesh.X_m.col(a);
  for (int e = 0; e < mesh.num_tets(); ++e) {
    for (int c = 0; c < 4; ++c) shuffled.tets(c, e) = shuffled_id[mesh.tets(c, e)];
  }
  auto run = [](const TetMesh& m, const std::vector<int>& node_id) {
    BoundaryConditions conditions;
    for (int a : std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}) {
      for (int axis = 0; axis < 3; ++axis) conditions.fixed_dofs.push_back(3 * node_id[a] + axis);
    }
    for (int a = 100; a < 110; ++a) conditions.prescribed_dofs.push_back(3 * node_id[a] + 2);
    TledSolver<float> solver(std::make_shared<const TledModel<float>>(m, Material{}), conditions, SolverOptions{});
    solver.Advance(200, std::vector<double>(conditions.prescribed_dofs.size(), -1e-3));
    std::vector<float> state;  // displacement and reaction of every node of the unshuffled mesh
    for (size_t a = 0; a < node_id.size(); ++a) {
      for (int i = 0; i < 3; ++i) state.push_back(solver.displacement()[3 * node_id[a] + i]);
      for (int i = 0; i < 3; ++i) state.push_back(solver.reaction_forces()[3 * node_id[a] + i]);
    }
    return state;
  };
  std::vector<int> identity(mesh.num_nodes());
  std::iota(identity.begin(), identity.end(), 0);
  const std::vector<float> original = run(mesh, identity);
  REQUIRE(run(shuffled, shuffled_id) == original);
  // The run moved: the comparison is not between two zero states.
  REQUIRE(*std::max_element(original.begin(), original.end()) > 1e-5f);
}

}  // namespace dg::sim

namespace dg::sim {

// At rest under gravity and a point load, the supports carry exactly the
// weight and the load (static equilibrium of the whole body).
TEST_CASE("tled solver: supports carry weight and external load", "[sim][unit]") {
  const TetMesh mesh = MakeBoxMesh(4, 4, 4, {0.01, 0.01, 0.01}, 0.25);
  const Material material{3e3, 0.45, 1e3};
  BoundaryConditions conditions;
  for (int axis = 0; axis < 3; ++axis) {
    for (int dof : Dofs(mesh.node_sets.at("zmin"), axis)) conditions.fixed_dofs.push_back(dof);
  }
  SolverOptions options;
  options.gravity_m_s2 = {0, 0, -9.81};
  options.damping_per_s = 400;
  TledSolver<double> solver(std::make_shared<const TledModel<double>>(mesh, material), conditions, options);
  std::vector<double> load(3 * mesh.num_nodes(), 0.0);
  const int corner = NodesInBox(mesh, {0.01, 0.01, 0.01}, {0.01, 0.01, 0.01}, 1e-9).at(0);
  load[3 * corner + 0] = 2e-3;
  load[3 * corner + 2] = -1e-3;
  solver.SetExternalForces(load);
  solver.Advance(2000, {});  // 0.4 s: many relaxation times
  Eigen::Vector3d support = Eigen::Vector3d::Zero();
  for (int dof : conditions.fixed_dofs) support[dof % 3] += solver.reaction_forces()[dof];
  const double weight = material.density_kg_m3 * 1e-6 * 9.81;
  REQUIRE(support.x() == Approx(-2e-3).epsilon(1e-6));
  REQUIRE(support.y() == Approx(0).margin(1e-9));
  REQUIRE(support.z() == Approx(weight + 1e-3).epsilon(1e-6));
}

}  // namespace dg::sim
