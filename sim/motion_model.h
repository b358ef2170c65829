#pragma once

#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace dg::sim {

// The preoperative motion as a function of cardiac phase (paper section 2.4):
// every degree of freedom follows a periodic uniform cubic B-spline over phase
// in [0, 1), with one control point per scan phase. Phase k of P sits on knot
// k / P. With smoothing 0 the spline interpolates the phases: for control
// points c, the value at knot k is (c[k-1] + 4 c[k] + c[k+1]) / 6, a circulant
// system A c = d. With smoothing lambda > 0 it minimises
//   |A c - d|^2 + lambda |D2 c|^2      (D2: cyclic second differences of c),
// trading fidelity at the phases for a smoother cycle (the paper's temporal
// smoothing of the registration's noise). The fit is one P x P matrix applied
// to all degrees of freedom at once.
//
// Immutable after construction; Evaluate() is const and thread-safe. Evaluation
// is four scaled sums of contiguous rows, so it vectorises over the degrees of freedom.
class CyclicMotionModel {
 public:
  // phase_displacements_m: [phase][dof] with dofs = 3 * nodes (xyz interleaved),
  // as scan.h5's /phases/node_displacement_m [phase, node, xyz] holds them;
  // phases uniformly spaced over one cycle, phase k at k / phases; period_s the
  // cardiac period over which the cycle repeats.
  // @throws dg::Error for fewer than 4 phases, a size mismatch, a non-finite
  // value, a non-positive period or a negative smoothing weight.
  CyclicMotionModel(const std::vector<double>& phase_displacements_m, int phases, int dofs, double period_s,
                    double smoothing = 0.0);

  int phases() const { return phases_; }
  int dofs() const { return dofs_; }
  double period_s() const { return period_s_; }
  double smoothing() const { return smoothing_; }

  // Displacement of every dof at `phase` (any real number; the cycle repeats).
  // @pre out.size() == dofs()
  template <typename T>
  void Evaluate(double phase, std::span<T> out) const;
  // The same for dofs [first_dof, first_dof + out.size()) only, bitwise equal
  // to those of Evaluate(): a caller may evaluate a node range where it uses it.
  // @pre the range lies within [0, dofs())
  template <typename T>
  void Evaluate(double phase, int first_dof, std::span<T> out) const;

  // The same motion with its nodes renumbered: node k of the result is node
  // nodes[k] of this one (bitwise the same values).
  // @pre nodes is a permutation of [0, dofs() / 3)
  CyclicMotionModel Reordered(std::span<const int> nodes) const;

  // Phase at time t_s of a clock whose phase was phase_at_zero at t = 0.
  double PhaseAt(double t_s, double phase_at_zero) const { return phase_at_zero + t_s / period_s_; }

 private:
  CyclicMotionModel() = default;

  int phases_ = 0, dofs_ = 0;
  double period_s_ = 0, smoothing_ = 0;
  Eigen::MatrixXd control_;  // [dof][phase]: column k is control point k of every dof
};

}  // namespace dg::sim
