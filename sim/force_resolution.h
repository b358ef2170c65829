#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "sim/aligned_vector.h"
#include "sim/tled_model.h"

namespace dg::sim {

// The element with the smallest volume ratio J = det F at displacement u (3 per
// node, computed in double), and that J: where a geometry is worst.
struct WorstElement {
  int element = -1;
  double volume_ratio = 0;
};
template <typename T>
WorstElement FindWorstElement(const TetMesh& mesh, const T* u);

// The error for a geometry whose edge triples cannot carry weights: the worst
// element of `mesh` in it (named as ElementName does), and `when` names the
// geometry (e.g. "motion model, phase 0.35").
[[noreturn]] void ThrowDegenerateEdges(const TetMesh& mesh, const WorstElement& worst, double min_volume_ratio,
                                       const std::string& when);

// Force resolution (paper eq. 5): a recovered nodal force r at node a, shared
// equally by the n_a elements of a, is written in each element e as a
// combination of that element's three edge vectors from a,
//   r / n_a = w0 b0 + w1 b1 + w2 b2,       b_k = x_{j_k} - x_a,
// in the geometry in which r was recovered (the motion model's, at that time).
// Applying the force to another geometry (the constrained forward simulation's)
// uses the same weights with that geometry's edges, so the force turns and
// stretches with the element it acts in: under a rigid rotation of the mesh it
// rotates with it, and where nothing constrains the motion it is r again.
//
// Per element, with D = [d1 d2 d3], d_j = x_j - x_0, the edges from corner 0,
// the weights of corner c are stored as q_c = D^-1 (r_c / n_c), the force's
// coordinates in those edges: corner 0's eq. 5 weights are q itself, and
// corner c >= 1's on its own edges x_j - x_c = d_j - d_c are q_j towards
// corners j != 0, c and -(q1 + q2 + q3) towards corner 0. That relabelling
// does not depend on the geometry, so applying the weights to any geometry's
// edges is f_c = D' q_c: one 3x3 inverse per element serves all four corners,
// and one edge matrix all four applications. Edges are formed as reference
// edges (TledModel::block_reference_edges, precomputed in double) plus
// displacement differences, which keeps float's digits for millimetre edges. Storage: the kernel's block layout,
// [block][corner][coordinate][lane].
//
// Threading: Resolve() and Apply() run under tbb::parallel_for in fixed
// chunks: results do not depend on the thread count. They use separate
// buffers, so one Resolve() and one Apply() may run at once (the coupled
// simulation does), but not two of the same. Neither allocates.
template <typename T>
class ForceResolution {
 public:
  // An element whose volume falls below this fraction of its reference volume
  // has a near-degenerate edge triple: its weights would amplify round-off.
  static constexpr double kMinVolumeRatio = 0.02;

  explicit ForceResolution(std::shared_ptr<const TledModel<T>> model);

  size_t weights_size() const { return model_->force_array_size(); }

  // Per-node spans are in the mesh's node order.
  // Weights of forces_n (3 per node, N) in the geometry X + u_model (3 per node, m).
  // @throws dg::Error naming the element if an edge triple is degenerate there.
  void Resolve(std::span<const T> u_model, std::span<const T> forces_n, std::span<T> weights);

  // The nodal forces the weights imply in the geometry X + u (3 per node).
  void Apply(std::span<const T> weights, std::span<const T> u, std::span<T> forces_n);

  // Set-up check of a geometry the forces will be resolved in; `when` names it
  // (e.g. "motion model, phase 0.35") in the error.
  // @throws dg::Error naming the element with the smallest volume ratio if it is below kMinVolumeRatio.
  void CheckGeometry(std::span<const T> u, const std::string& when) const;

 private:
  std::shared_ptr<const TledModel<T>> model_;
  std::vector<T> inverse_count_;    // per node: 1 / (number of its elements)
  AlignedVector<T> corner_forces_;  // Apply()'s element-major forces, as the TLED kernel's
  std::vector<T> chunk_min_ratio_;  // Resolve()'s smallest volume ratio per chunk
  std::vector<T> layout_u_, layout_forces_;  // the per-node arguments in layout order
};

extern template class ForceResolution<float>;
extern template class ForceResolution<double>;

}  // namespace dg::sim
