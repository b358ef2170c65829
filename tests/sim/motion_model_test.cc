#include "sim/motion_model.h"

#include <cmath>
#include <numbers>

#include <catch2/catch.hpp>

#include "sim/error.h"

namespace dg::sim {
namespace {

using Catch::Matchers::Contains;
using Catch::Matchers::WithinAbs;

// P phases of f sampled at k / P, for one dof.
std::vector<double> Sample(int P, double (*f)(double)) {
  std::vector<double> values(P);
  for (int k = 0; k < P; ++k) values[k] = f(double(k) / P);
  return values;
}

double Evaluate1(const CyclicMotionModel& model, double phase) {
  double value = 0;
  model.Evaluate<double>(phase, std::span<double>(&value, 1));
  return value;
}

double Sine(double phase) { return std::sin(2 * std::numbers::pi * phase) + 0.3 * std::cos(4 * std::numbers::pi * phase); }

// Interpolating: the spline passes through every phase, repeats every cycle,
// and follows a smooth periodic function within the cubic spline's error bound
// 5/384 h^4 max|f''''| (de Boor), h = 1/P.
TEST_CASE("motion model: interpolates phases, is cyclic, meets the spline error bound", "[unit]") {
  const int P = 20;
  const CyclicMotionModel model(Sample(P, Sine), P, 1, 0.8);
  for (int k = 0; k < P; ++k) REQUIRE_THAT(Evaluate1(model, double(k) / P), WithinAbs(Sine(double(k) / P), 1e-13));
  const double two_pi = 2 * std::numbers::pi;
  const double max_f4 = std::pow(two_pi, 4) * (1 + 0.3 * 16);
  const double bound = 5.0 / 384.0 * std::pow(1.0 / P, 4) * max_f4;
  double worst = 0;
  for (int i = 0; i < 1000; ++i) {
    const double phase = i / 1000.0;
    worst = std::max(worst, std::abs(Evaluate1(model, phase) - Sine(phase)));
    REQUIRE_THAT(Evaluate1(model, phase + 3), WithinAbs(Evaluate1(model, phase), 1e-12));
    REQUIRE_THAT(Evaluate1(model, phase - 2), WithinAbs(Evaluate1(model, phase), 1e-12));
  }
  REQUIRE(worst <= bound);
  REQUIRE(worst > bound / 100);  // the bound is tight enough to mean something
  REQUIRE(model.PhaseAt(1.2, 0.25) == Approx(0.25 + 1.2 / 0.8));
}

// Smoothing, against the circulant algebra: data alternating +1/-1 (the
// highest frequency P phases can hold) is an eigenvector of both A (eigenvalue
// 1/3) and D2 (-4), so the fitted values at the phases are scaled by
// (1/9) / (1/9 + 16 lambda); a constant (eigenvalues 1 and 0) is kept exactly.
TEST_CASE("motion model: smoothing damps the alternating mode by the analytic factor", "[unit]") {
  const int P = 8;
  std::vector<double> data(2 * P);  // dof 0 alternates, dof 1 is constant: [phase][dof]
  for (int k = 0; k < P; ++k) {
    data[2 * k] = k % 2 ? -1.0 : 1.0;
    data[2 * k + 1] = 0.7;
  }
  for (double lambda : {0.0, 0.01, 0.1, 1.0}) {
    const CyclicMotionModel model(data, P, 2, 1.0, lambda);
    const double factor = (1.0 / 9.0) / (1.0 / 9.0 + 16 * lambda);
    for (int k = 0; k < P; ++k) {
      double values[2];
      model.Evaluate<double>(double(k) / P, values);
      REQUIRE_THAT(values[0], WithinAbs((k % 2 ? -1.0 : 1.0) * factor, 1e-12));
      REQUIRE_THAT(values[1], WithinAbs(0.7, 1e-12));
    }
  }
}

// All dofs at once, float and double agree (the float path only rounds the result).
TEST_CASE("motion model: vectorised float evaluation matches double", "[unit]") {
  const int P = 10, dofs = 301;
  std::vector<double> data(P * dofs);
  for (int k = 0; k < P; ++k) {
    for (int d = 0; d < dofs; ++d) data[k * dofs + d] = 1e-3 * std::sin(0.1 * d + 2 * std::numbers::pi * k / P);
  }
  const CyclicMotionModel model(data, P, dofs, 1.0, 0.05);
  std::vector<double> u(dofs);
  std::vector<float> uf(dofs);
  model.Evaluate<double>(0.3712, u);
  model.Evaluate<float>(0.3712, uf);
  for (int d = 0; d < dofs; ++d) REQUIRE_THAT(double(uf[d]), WithinAbs(u[d], 1e-3 * 1e-6));
}

TEST_CASE("motion model: bad input is rejected with a reason", "[unit]") {
  REQUIRE_THROWS_WITH(CyclicMotionModel(std::vector<double>(3, 0.0), 3, 1, 1.0), Contains("at least 4"));
  REQUIRE_THROWS_WITH(CyclicMotionModel(std::vector<double>(8, 0.0), 4, 3, 1.0), Contains("expected 4 phases"));
  REQUIRE_THROWS_WITH(CyclicMotionModel(std::vector<double>(4, 0.0), 4, 1, 0.0), Contains("period"));
  REQUIRE_THROWS_WITH(CyclicMotionModel(std::vector<double>(4, 0.0), 4, 1, 1.0, -1), Contains("smoothing"));
  std::vector<double> bad(4, 0.0);
  bad[2] = std::nan("");
  REQUIRE_THROWS_WITH(CyclicMotionModel(bad, 4, 1, 1.0), Contains("phase 2"));
}

}  // namespace
}  // namespace dg::sim
