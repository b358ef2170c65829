#include "sim/coupled_simulation.h"

#include <cmath>
#include <numbers>

#include <catch2/catch.hpp>
#include <tbb/global_control.h>

#include "sim/error.h"
#include "tests/sim/box_mesh.h"

namespace dg::sim {
namespace {

using Catch::Matchers::Contains;
using testing::MakeBoxMesh;

constexpr double kPeriod_s = 2.0 / 3.0;  // 90 beats per minute
constexpr double kDt_s = 2e-4;
constexpr int kPhases = 10;

// A 2 cm block on a mount (z = 0) that beats: with w = (z/H)^2 and a beat
// a(phase) = sin^2(pi phase), it contracts radially by 12% a w, twists by
// 0.15 a w rad and shortens by 8% a z/H, like the phantom. Sampled at kPhases
// phases into a motion model, as a 4D CT would be.
struct BeatingBox {
  std::shared_ptr<const TledModel<double>> model_double;
  std::shared_ptr<const TledModel<float>> model_float;
  std::shared_ptr<const CyclicMotionModel> motion;
  std::vector<int> base, surface;  // fixed nodes; free boundary nodes
};

BeatingBox MakeBeatingBox(double amplitude = 1.0) {
  const double H = 0.02;
  TetMesh mesh = MakeBoxMesh(4, 4, 4, {H, H, H}, 0.15);
  BeatingBox box;
  box.model_double = std::make_shared<const TledModel<double>>(mesh, Material{});
  box.model_float = std::make_shared<const TledModel<float>>(mesh, Material{});
  std::vector<double> phases;
  for (int k = 0; k < kPhases; ++k) {
    const double a = amplitude * std::pow(std::sin(std::numbers::pi * k / kPhases), 2);
    for (int n = 0; n < mesh.num_nodes(); ++n) {
      const Eigen::Vector3d X = mesh.X_m.col(n) - Eigen::Vector3d(H / 2, H / 2, 0);
      const double zeta = X.z() / H, w = zeta * zeta;
      const double angle = 0.15 * a * w, scale = 1 - 0.12 * a * w;
      const Eigen::Vector3d x(scale * (std::cos(angle) * X.x() - std::sin(angle) * X.y()),
                              scale * (std::sin(angle) * X.x() + std::cos(angle) * X.y()), X.z() * (1 - 0.08 * a * zeta));
      for (int i = 0; i < 3; ++i) phases.push_back(x[i] - X[i]);
    }
  }
  box.motion = std::make_shared<const CyclicMotionModel>(phases, kPhases, 3 * mesh.num_nodes(), kPeriod_s);
  box.base = mesh.node_sets.at("zmin");
  for (int n : BoundaryNodes(mesh)) {
    if (!std::binary_search(box.base.begin(), box.base.end(), n)) box.surface.push_back(n);
  }
  return box;
}

template <typename T>
std::shared_ptr<const TledModel<T>> ModelOf(const BeatingBox& box) {
  if constexpr (sizeof(T) == 4) {
    return box.model_float;
  } else {
    return box.model_double;
  }
}

template <typename T>
CoupledSimulation<T> MakeSimulation(const BeatingBox& box, SimulationMode mode, bool concurrent = true,
                                    int inverse_interval = kDefaultInverseIntervalSteps) {
  CoupledOptions options;
  options.mode = mode;
  options.solver.dt_s = kDt_s;
  options.phase_at_start = 0.1;
  options.concurrent = concurrent;
  options.inverse_interval_steps = inverse_interval;
  return CoupledSimulation<T>(ModelOf<T>(box), box.motion, box.base, options);
}

// Largest node distance between the simulation and its motion model now, metres.
template <typename T>
double DistanceFromMotion(const CoupledSimulation<T>& simulation) {
  std::vector<T> expected(simulation.displacement().size());
  simulation.MotionAtStep(simulation.steps_taken(), expected);
  double worst = 0;
  for (size_t i = 0; i < expected.size(); ++i) {
    worst = std::max(worst, std::abs(double(simulation.displacement()[i]) - double(expected[i])));
  }
  return worst;
}

// Targets of the constrained nodes at a step: the motion model's own displacement there.
template <typename T>
std::vector<double> MotionTargets(const CoupledSimulation<T>& simulation, long long step) {
  std::vector<T> u(simulation.displacement().size());
  simulation.MotionAtStep(step, u);
  std::vector<double> targets;
  for (int n : simulation.constrained_nodes()) {
    for (int i = 0; i < 3; ++i) targets.push_back(u[3 * n + i]);
  }
  return targets;
}

// Paper section 2.6, "by construction": with no constraints, the forces
// recovered from the motion model and resolved into the current geometry move
// the mesh along the motion model. Over three cycles (10000 steps of 0.2 ms):
//  - recovered every step, every node stays on it to round-off: under
//    2.5e-8 m in float (the 3 mm motion's single-precision increments, damped
//    by alpha; 1.1e-8 measured) and 1e-15 m in double (3e-17 measured);
//  - recovered every k steps and blended in between, the error is the linear
//    interpolation's, which grows as k^2 (docs/solver.md): 0.065 um at k = 8
//    and 2.4 um at k = 50 (measured, double; float adds its round-off), in
//    double a ratio within 25% of (50/8)^2 = 39.
TEMPLATE_TEST_CASE("coupled simulation: volume mode reproduces the motion model over three cycles", "[integration]",
                   float, double) {
  const BeatingBox box = MakeBeatingBox();
  const bool in_float = sizeof(TestType) == 4;
  auto largest_deviation = [&](int interval) {
    CoupledSimulation<TestType> simulation = MakeSimulation<TestType>(box, SimulationMode::kVolume, true, interval);
    const int steps = static_cast<int>(std::lround(3 * kPeriod_s / kDt_s));
    double worst = 0;
    for (int s = 0; s < steps; s += 50) {
      simulation.Advance(50, {});
      worst = std::max(worst, DistanceFromMotion(simulation));
    }
    return worst;
  };
  const double every_step = largest_deviation(1), every_8 = largest_deviation(8),
               every_50 = largest_deviation(kMaxInverseIntervalSteps);
  INFO("largest deviation from the motion model, recovered every 1, 8, 50 steps: " << every_step * 1e6 << ", "
       << every_8 * 1e6 << ", " << every_50 * 1e6 << " um");
  REQUIRE(every_step < (in_float ? 2.5e-8 : 1e-15));
  REQUIRE(every_8 < (in_float ? 1.8e-7 : 1.3e-7));
  REQUIRE(every_50 < 5e-6);
  if (!in_float) REQUIRE_THAT(every_50 / every_8, Catch::Matchers::WithinRel(std::pow(50.0 / 8.0, 2), 0.25));
  // The motion is not trivial: the top moves by millimetres.
  std::vector<TestType> peak(3 * size_t(box.model_double->num_nodes()));
  MakeSimulation<TestType>(box, SimulationMode::kVolume)
      .MotionAtStep(static_cast<long long>(std::lround((0.5 - 0.1) * kPeriod_s / kDt_s)), peak);
  REQUIRE(*std::max_element(peak.begin(), peak.end()) > 1e-3);
}

// Combined mode with every free surface node constrained to the motion
// model's own surface displacement (given at every step) also stays on the
// motion model: the constraints agree with the forces.
TEMPLATE_TEST_CASE("coupled simulation: combined mode with the model's own surface motion equals the model",
                   "[integration]", float, double) {
  const BeatingBox box = MakeBeatingBox();
  CoupledSimulation<TestType> simulation = MakeSimulation<TestType>(box, SimulationMode::kCombined);
  simulation.SetConstrainedNodes(box.surface);
  const int steps = static_cast<int>(std::lround(3 * kPeriod_s / kDt_s));
  double worst = 0;
  for (int s = 0; s < steps; ++s) {
    simulation.Advance(1, MotionTargets(simulation, simulation.steps_taken() + 1));
    if (s % 50 == 0) worst = std::max(worst, DistanceFromMotion(simulation));
  }
  INFO("largest deviation from the motion model: " << worst * 1e3 << " mm");
  REQUIRE(worst < 1e-6);
}

// The surface drives the body where the forces alone would not: constraining
// the surface to a beat of 1.3x the scan's amplitude pulls the interior away
// from the motion model, and concurrent and sequential inverse/forward, with
// one thread or two, give bitwise the same displacements (every partial sum
// runs in fixed chunks, and the two tasks share no data).
TEST_CASE("coupled simulation: concurrent and sequential, 1 and 2 threads, agree bitwise", "[integration]") {
  const BeatingBox box = MakeBeatingBox();
  const BeatingBox stronger = MakeBeatingBox(1.3);
  auto run = [&](bool concurrent, int threads) {
    tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
    CoupledSimulation<float> simulation = MakeSimulation<float>(box, SimulationMode::kCombined, concurrent);
    std::vector<int> top = box.model_float->mesh().node_sets.at("zmax");
    simulation.SetConstrainedNodes(top);
    std::vector<float> u(simulation.displacement().size());
    for (int frame = 1; frame <= 12; ++frame) {
      const long long step = frame * 167LL;
      stronger.motion->Evaluate<float>(stronger.motion->PhaseAt(step * kDt_s, 0.1), u);
      std::vector<double> targets;
      for (int n : top) {
        for (int i = 0; i < 3; ++i) targets.push_back(u[3 * n + i]);
      }
      simulation.Advance(static_cast<int>(step - simulation.steps_taken()), targets);
    }
    return std::vector<float>(simulation.displacement().begin(), simulation.displacement().end());
  };
  const std::vector<float> reference = run(false, 1);
  REQUIRE(run(true, 2) == reference);
  REQUIRE(run(true, 1) == reference);
  REQUIRE(run(false, 2) == reference);
  CoupledSimulation<float> unconstrained = MakeSimulation<float>(box, SimulationMode::kVolume);
  unconstrained.Advance(12 * 167, {});
  double difference = 0;
  for (size_t i = 0; i < reference.size(); ++i) {
    difference = std::max(difference, std::abs(double(reference[i]) - double(unconstrained.displacement()[i])));
  }
  REQUIRE(difference > 1e-4);  // the constraints did act
}

// The inverse simulation's fused passes (forces, edge inverses and resolution
// one level apart) compute what ForceRecovery followed by
// ForceResolution::Resolve computes level by level from the motion model: at
// every step, and at every third step with the forward step's own stencil.
TEST_CASE("inverse simulation: weights equal recovery then resolution at every level", "[unit]") {
  const BeatingBox box = MakeBeatingBox();
  SolverOptions options;
  options.dt_s = 2e-3;  // ten times the paper's step: larger increments, same identity
  options.gravity_m_s2 = Eigen::Vector3d(0, 0, -9.81);
  const double phase_at_start = 0.3;
  const int interval = GENERATE(1, 3);
  InverseSimulation<double> inverse(box.model_double, box.motion, options, phase_at_start, interval);
  ForceRecovery<double> recovery(box.model_double, options);
  ForceResolution<double> resolution(box.model_double);
  const size_t n_dofs = 3 * size_t(box.model_double->num_nodes());
  std::vector<double> u_prev(n_dofs), u(n_dofs), u_next(n_dofs), forces(n_dofs), weights(resolution.weights_size());
  auto motion_at = [&](long long step, std::vector<double>& out) {
    box.motion->Evaluate<double>(box.motion->PhaseAt(step * options.dt_s, phase_at_start), out);
  };
  for (int level = 1; level < 40; ++level) {
    REQUIRE(inverse.level() == level);
    const long long step = level * interval;
    motion_at(step - 1, u_prev);
    motion_at(step, u);
    motion_at(step + 1, u_next);
    recovery.Recover(u_prev, u, u_next, forces);
    resolution.Resolve(u, forces, weights);
    double scale = 0, difference = 0;
    for (size_t i = 0; i < weights.size(); ++i) {
      scale = std::max(scale, std::abs(weights[i]));
      difference = std::max(difference, std::abs(weights[i] - inverse.weights(level)[i]));
    }
    REQUIRE(scale > 0);
    REQUIRE(difference <= 1e-12 * scale);
    inverse.Advance();
  }
}

TEST_CASE("coupled simulation: bad set-up is an error with a reason", "[unit]") {
  const BeatingBox box = MakeBeatingBox();
  CoupledOptions options;
  options.mode = SimulationMode::kVolume;
  REQUIRE_THROWS_WITH(CoupledSimulation<double>(box.model_double, nullptr, box.base, options),
                      Contains("needs the preoperative motion"));
  options.solver.time_step_policy = TimeStepPolicy::kSubstep;
  REQUIRE_THROWS_WITH(CoupledSimulation<double>(box.model_double, box.motion, box.base, options),
                      Contains("substepping"));
  REQUIRE_THROWS_WITH(ParseSimulationMode("both"), Contains("surface, volume or combined"));
  // A motion that folds the block flat at peak systole (shortening 100%).
  const int N = box.model_double->num_nodes();
  std::vector<double> folding(kPhases * 3 * N, 0.0);
  for (int n = 0; n < N; ++n) folding[(kPhases / 2) * 3 * N + 3 * n + 2] = -box.model_double->mesh().X_m(2, n);
  options.solver.time_step_policy = TimeStepPolicy::kRefuse;
  REQUIRE_THROWS_WITH(CoupledSimulation<double>(box.model_double,
                                                std::make_shared<const CyclicMotionModel>(folding, kPhases, 3 * N, 1.0),
                                                box.base, options),
                      Contains("degenerate edge triple") && Contains("phase 0.5"));
  CoupledSimulation<double> simulation(box.model_double, box.motion, box.base, options);
  REQUIRE_THROWS_WITH(simulation.SetConstrainedNodes({box.base[0]}), Contains("fixed"));
  REQUIRE_THROWS_WITH(simulation.Advance(1, std::vector<double>(3, 0.0)), Contains("3 values per constrained node"));
}

}  // namespace
}  // namespace dg::sim
