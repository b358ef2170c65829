#include "sim/motion_model.h"

#include <cmath>

#include <Eigen/Cholesky>

#include "sim/cubic_bspline.h"
#include "sim/error.h"

namespace dg::sim {
namespace {

// Circulant P x P matrix with `left`, `centre`, `right` on the three cyclic diagonals.
Eigen::MatrixXd Circulant(int P, double left, double centre, double right) {
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(P, P);
  for (int k = 0; k < P; ++k) {
    m(k, (k + P - 1) % P) += left;
    m(k, k) += centre;
    m(k, (k + 1) % P) += right;
  }
  return m;
}

}  // namespace

CyclicMotionModel::CyclicMotionModel(const std::vector<double>& phase_displacements_m, int phases, int dofs,
                                     double period_s, double smoothing)
    : phases_(phases), dofs_(dofs), period_s_(period_s), smoothing_(smoothing) {
  const std::string where = "cyclic motion model";
  if (phases < 4) {
    throw Error("the motion has " + std::to_string(phases) + " phases; a cyclic cubic spline needs at least 4",
                where, "give at least 4 scan phases over the cycle");
  }
  if (dofs < 1 || phase_displacements_m.size() != size_t(phases) * size_t(dofs)) {
    throw Error("the motion holds " + std::to_string(phase_displacements_m.size()) + " values, expected " +
                    std::to_string(phases) + " phases x " + std::to_string(dofs) + " degrees of freedom",
                where, "give [phase][node][xyz] displacements for every node of the mesh");
  }
  if (!(std::isfinite(period_s) && period_s > 0)) {
    throw Error("cardiac period must be positive and finite", where, "give the scan's period in seconds");
  }
  if (!(std::isfinite(smoothing) && smoothing >= 0)) {
    throw Error("smoothing weight must be zero (interpolation) or positive", where, "give lambda >= 0");
  }
  for (size_t i = 0; i < phase_displacements_m.size(); ++i) {
    if (!std::isfinite(phase_displacements_m[i])) {
      throw Error("displacement is not finite", "phase " + std::to_string(i / dofs) + ", node " +
                      std::to_string(i % dofs / 3) + ", axis " + std::to_string(i % 3),
                  "check the scan's registration output");
    }
  }
  // Normal equations (A^T A + lambda D2^T D2) c = A^T d; both circulants are
  // symmetric positive definite (A's eigenvalues are (4 + 2 cos)/6 >= 1/3).
  const Eigen::MatrixXd A = Circulant(phases, 1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0);
  const Eigen::MatrixXd D2 = Circulant(phases, 1.0, -2.0, 1.0);
  const Eigen::MatrixXd normal = A.transpose() * A + smoothing * D2.transpose() * D2;
  const Eigen::MatrixXd fit = normal.llt().solve(A.transpose());  // P x P: control = fit * data
  const Eigen::Map<const Eigen::MatrixXd> data(phase_displacements_m.data(), dofs, phases);  // [dof][phase]
  control_ = data * fit.transpose();
}

CyclicMotionModel CyclicMotionModel::Reordered(std::span<const int> nodes) const {
  DG_CHECK(3 * nodes.size() == size_t(dofs_));
  CyclicMotionModel reordered;
  reordered.phases_ = phases_;
  reordered.dofs_ = dofs_;
  reordered.period_s_ = period_s_;
  reordered.smoothing_ = smoothing_;
  reordered.control_.resize(control_.rows(), control_.cols());
  for (size_t k = 0; k < nodes.size(); ++k) reordered.control_.middleRows<3>(3 * k) = control_.middleRows<3>(3 * nodes[k]);
  return reordered;
}

template <typename T>
void CyclicMotionModel::Evaluate(double phase, std::span<T> out) const {
  DG_CHECK(out.size() == size_t(dofs_));
  Evaluate(phase, 0, out);
}

template <typename T>
void CyclicMotionModel::Evaluate(double phase, int first_dof, std::span<T> out) const {
  DG_CHECK(first_dof >= 0 && size_t(first_dof) + out.size() <= size_t(dofs_));
  const double s = (phase - std::floor(phase)) * phases_;
  int i = static_cast<int>(std::floor(s));
  const double t = s - i;
  i %= phases_;  // s may round up to exactly phases_
  double b[4];
  CubicBSplineWeights(t, b);
  const double* c[4];
  for (int m = 0; m < 4; ++m) c[m] = control_.col((i + phases_ - 1 + m) % phases_).data() + first_dof;
  T* __restrict u = out.data();
  const int count = static_cast<int>(out.size());
  for (int d = 0; d < count; ++d) {
    u[d] = static_cast<T>(b[0] * c[0][d] + b[1] * c[1][d] + b[2] * c[2][d] + b[3] * c[3][d]);
  }
}

template void CyclicMotionModel::Evaluate<float>(double, std::span<float>) const;
template void CyclicMotionModel::Evaluate<double>(double, std::span<double>) const;
template void CyclicMotionModel::Evaluate<float>(double, int, std::span<float>) const;
template void CyclicMotionModel::Evaluate<double>(double, int, std::span<double>) const;

}  // namespace dg::sim
