#include "sim/stability.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include <malloc.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "sim/tled_kernel.h"
#include "sim/tled_model.h"

namespace dg::sim {
namespace {

// Internal forces of the whole mesh at displacement u (3N), in double, both
// in the mesh's node order.
Eigen::VectorXd InternalForces(const TledModel<double>& model, const Eigen::VectorXd& u,
                               std::vector<double>* scratch) {
  Eigen::VectorXd layout_u(u.size()), layout_f(u.size()), f(u.size());
  model.ToLayout(std::span<const double>(u.data(), u.size()), std::span<double>(layout_u.data(), u.size()));
  ComputeElementForces(model, layout_u.data(), scratch->data(), 0, model.num_blocks());
  for (int a = 0; a < model.num_nodes(); ++a) GatherNodalForce(model, scratch->data(), a, &layout_f[3 * a]);
  model.ToMeshOrder(std::span<const double>(layout_f.data(), u.size()), std::span<double>(f.data(), u.size()));
  return f;
}

// Smallest altitude of element e: 3 V / (largest face area).
double SmallestAltitude(const TetMesh& mesh, int e) {
  Eigen::Vector3d x[4];
  for (int c = 0; c < 4; ++c) x[c] = mesh.X_m.col(mesh.tets(c, e));
  const double volume = std::abs(SixSignedVolume(mesh, e)) / 6.0;
  double largest_face = 0;
  for (int skip = 0; skip < 4; ++skip) {
    const Eigen::Vector3d& p = x[(skip + 1) % 4];
    const Eigen::Vector3d& q = x[(skip + 2) % 4];
    const Eigen::Vector3d& r = x[(skip + 3) % 4];
    largest_face = std::max(largest_face, 0.5 * (q - p).cross(r - p).norm());
  }
  return 3.0 * volume / largest_face;
}

}  // namespace

std::string StabilityReport::Describe() const {
  char text[400];
  std::snprintf(text, sizeof text,
                "critical time step %.4g ms (assembled mesh, omega_max %.4g rad/s, highest mode "
                "largest at node %d (%.1f, %.1f, %.1f) mm; Lanczos %d iterations, residual %.1e); "
                "per-element bound %.4g ms",
                dt_critical_s * 1e3, omega_max_rad_s, limiting_node, limiting_node_position_m.x() * 1e3,
                limiting_node_position_m.y() * 1e3, limiting_node_position_m.z() * 1e3,
                lanczos_iterations, relative_residual, dt_element_bound_s * 1e3);
  const std::string element =
      limiting_element_name.empty() ? "element " + std::to_string(limiting_element) : limiting_element_name;
  return std::string(text) + " (" + element + ")";
}

std::string StabilityReport::TimeStepExcess(double dt_s, double safety) const {
  if (dt_s <= safety * dt_critical_s) return {};
  char text[64];
  std::snprintf(text, sizeof text, "time step %.4g ms exceeds %.2f x the ", dt_s * 1e3, safety);
  return text + Describe();
}

namespace {

StabilityReport EstimateStabilityOnce(const TetMesh& mesh, const Material& material,
                                      const std::vector<int>& constrained_dofs) {
  const TledModel<double> model(mesh, material, /*parts=*/1);  // serial: no halo to compute twice
  const int n = 3 * model.num_nodes();
  StabilityReport report;

  // Per-element bound.
  const double c = material.dilatational_wave_speed_m_s();
  report.dt_element_bound_s = std::numeric_limits<double>::infinity();
  double smallest_altitude = std::numeric_limits<double>::infinity();
  for (int e = 0; e < mesh.num_tets(); ++e) {
    const double altitude = SmallestAltitude(mesh, e);
    if (altitude < smallest_altitude) {
      smallest_altitude = altitude;
      report.limiting_element = e;
    }
  }
  report.dt_element_bound_s = smallest_altitude / c;
  report.limiting_element_name = ElementName(mesh, report.limiting_element);

  // A = M^-1/2 K M^-1/2 on the free degrees of freedom.
  Eigen::VectorXd inv_sqrt_mass(n), free = Eigen::VectorXd::Ones(n);
  for (int a = 0; a < model.num_nodes(); ++a) {
    inv_sqrt_mass.segment<3>(3 * a).setConstant(1.0 / std::sqrt(model.lumped_mass_kg()[model.layout_node(a)]));
  }
  for (int dof : constrained_dofs) free[dof] = 0;
  std::vector<double> scratch(model.force_array_size());
  // Probe amplitude: strains of about 1e-7, where K is the tangent to round-off
  // and the neo-Hookean nonlinearity is far below the estimate's accuracy.
  const double probe_m = 1e-7 * smallest_altitude;
  auto apply = [&](const Eigen::VectorXd& v) {
    Eigen::VectorXd x = free.cwiseProduct(inv_sqrt_mass.cwiseProduct(v));
    const double h = probe_m / std::max(x.cwiseAbs().maxCoeff(), 1e-300);
    const Eigen::VectorXd kx =
        (InternalForces(model, h * x, &scratch) - InternalForces(model, -h * x, &scratch)) / (2 * h);
    return Eigen::VectorXd(free.cwiseProduct(inv_sqrt_mass.cwiseProduct(kx)));
  };

  // Lanczos with full reorthogonalisation: the extreme Ritz value converges in
  // tens of steps where plain power iteration needs hundreds on fine meshes.
  constexpr int kMaxIterations = 120;
  constexpr double kTolerance = 1e-6;
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = uniform(rng) * free[i];
  v.normalize();
  std::vector<Eigen::VectorXd> basis{v};
  std::vector<double> alpha, beta;
  double theta = 0;
  Eigen::VectorXd ritz_vector;
  for (int k = 0; k < kMaxIterations; ++k) {
    Eigen::VectorXd w = apply(basis[k]);
    alpha.push_back(w.dot(basis[k]));
    for (int pass = 0; pass < 2; ++pass) {
      for (const Eigen::VectorXd& q : basis) w -= w.dot(q) * q;
    }
    beta.push_back(w.norm());

    const int m = k + 1;
    Eigen::MatrixXd tridiagonal = Eigen::MatrixXd::Zero(m, m);
    for (int i = 0; i < m; ++i) {
      tridiagonal(i, i) = alpha[i];
      if (i + 1 < m) tridiagonal(i, i + 1) = tridiagonal(i + 1, i) = beta[i];
    }
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(tridiagonal);
    theta = eigen.eigenvalues()[m - 1];
    const double residual = beta[k] * std::abs(eigen.eigenvectors()(m - 1, m - 1)) / theta;
    report.lanczos_iterations = m;
    report.relative_residual = residual;
    if (residual < kTolerance || beta[k] <= 1e-14 * theta || m == kMaxIterations || m == n) {
      ritz_vector = Eigen::VectorXd::Zero(n);
      for (int i = 0; i < m; ++i) ritz_vector += eigen.eigenvectors()(i, m - 1) * basis[i];
      break;
    }
    basis.push_back(w / beta[k]);
  }

  report.omega_max_rad_s = std::sqrt(theta);
  report.dt_critical_s = 2.0 / report.omega_max_rad_s;
  double largest = -1;
  for (int a = 0; a < model.num_nodes(); ++a) {
    const double amplitude = ritz_vector.segment<3>(3 * a).squaredNorm();
    if (amplitude > largest) {
      largest = amplitude;
      report.limiting_node = a;
    }
  }
  report.limiting_node_position_m = mesh.X_m.col(report.limiting_node);
  return report;
}

}  // namespace

StabilityReport EstimateStability(const TetMesh& mesh, const Material& material,
                                  const std::vector<int>& constrained_dofs) {
  const StabilityReport report = EstimateStabilityOnce(mesh, material, constrained_dofs);
  // The estimate's Lanczos basis (up to 120 vectors of 3N doubles: 45 MB on an
  // 80k-element mesh) and its double-precision model are freed by now, but
  // glibc keeps the pages; give them back, so a simulation does not hold its
  // set-up's peak while it steps.
  malloc_trim(0);
  return report;
}

double DefaultStabilitySafety(double poissons_ratio) {
  constexpr double kCompressible = 0.9, kIncompressible = 0.65;
  const double from = std::log10(1 - 2 * 0.45), to = std::log10(1 - 2 * 0.499);
  const double at = std::log10(std::max(1 - 2 * poissons_ratio, 1e-12));
  const double t = std::clamp((at - from) / (to - from), 0.0, 1.0);
  return kCompressible + t * (kIncompressible - kCompressible);
}

}  // namespace dg::sim
