#include "sim/force_resolution.h"

#include <algorithm>
#include <cstdio>
#include <limits>

#include <Eigen/LU>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "sim/element_measures.h"
#include "sim/error.h"
#include "sim/lane_loop.h"
#include "sim/tled_kernel.h"

namespace dg::sim {
namespace {


// Runs body(first_block, end_block) for the model's fixed block chunks in parallel.
template <typename T, typename Body>
void ForEachBlockChunk(const TledModel<T>& model, Body body) {
  tbb::parallel_for(tbb::blocked_range<int>(0, model.element_chunks()), [&](const tbb::blocked_range<int>& chunks) {
    for (int c = chunks.begin(); c != chunks.end(); ++c) {
      body(c, model.chunk_block_begin(c), model.chunk_block_begin(c + 1));
    }
  });
}

// The edge matrix D = D0 + (u_j - u_0) of one lane: columns d1, d2, d3 from
// corner 0, reference edges D0 ([edge][xyz] with lane stride) plus the
// displacement differences of the corners' dofs n0..n3.
template <typename T>
struct EdgeMatrix {
  EdgeMatrix(const T* D0, int stride, const T* u, int n0, int n1, int n2, int n3)
      : d1x(D0[0 * stride] + (u[n1] - u[n0])), d1y(D0[1 * stride] + (u[n1 + 1] - u[n0 + 1])),
        d1z(D0[2 * stride] + (u[n1 + 2] - u[n0 + 2])), d2x(D0[3 * stride] + (u[n2] - u[n0])),
        d2y(D0[4 * stride] + (u[n2 + 1] - u[n0 + 1])), d2z(D0[5 * stride] + (u[n2 + 2] - u[n0 + 2])),
        d3x(D0[6 * stride] + (u[n3] - u[n0])), d3y(D0[7 * stride] + (u[n3 + 1] - u[n0 + 1])),
        d3z(D0[8 * stride] + (u[n3 + 2] - u[n0 + 2])) {}
  T d1x, d1y, d1z, d2x, d2y, d2z, d3x, d3y, d3z;
};

// Weights of one block: q_c = D^-1 (r_c / n_c) for each corner c, with
// D = D0 + (u_j - u_0) the edge matrix from corner 0 in the geometry X + u;
// returns the block's smallest volume ratio det(D) / det(D0).
template <typename T>
T ResolveBlock(const TledModel<T>& model, int b, const T* __restrict D0, const T* __restrict u,
               const T* __restrict r, const T* __restrict inverse_count, T* __restrict q) {
  constexpr int W = TledModel<T>::kLanes;
  const int32_t* __restrict nodes = model.block_nodes(b);
  const T* __restrict V0 = model.block_volumes(b);
  alignas(64) T ratio[W];
  DG_LANE_LOOP
  for (int l = 0; l < W; ++l) {
    const int n0 = 3 * nodes[l], n1 = 3 * nodes[W + l], n2 = 3 * nodes[2 * W + l], n3 = 3 * nodes[3 * W + l];
    const EdgeMatrix<T> D(D0 + l, W, u, n0, n1, n2, n3);
    // Rows of D^-1 times det(D): d2 x d3, d3 x d1, d1 x d2.
    const T a0 = D.d2y * D.d3z - D.d2z * D.d3y, a1 = D.d2z * D.d3x - D.d2x * D.d3z,
            a2 = D.d2x * D.d3y - D.d2y * D.d3x;
    const T b0 = D.d3y * D.d1z - D.d3z * D.d1y, b1 = D.d3z * D.d1x - D.d3x * D.d1z,
            b2 = D.d3x * D.d1y - D.d3y * D.d1x;
    const T c0 = D.d1y * D.d2z - D.d1z * D.d2y, c1 = D.d1z * D.d2x - D.d1x * D.d2z,
            c2 = D.d1x * D.d2y - D.d1y * D.d2x;
    const T det = D.d1x * a0 + D.d1y * a1 + D.d1z * a2;
    const bool real = V0[l] > 0;  // padding lanes have no volume and no incidences
    ratio[l] = real ? det / (6 * V0[l]) : T(1);
    const T inv_det = real ? T(1) / det : T(0);
    const int corner_dof[4] = {n0, n1, n2, n3};
    for (int c = 0; c < 4; ++c) {
      const int n = corner_dof[c];
      const T scale = inv_det * inverse_count[n / 3];
      const T rx = r[n] * scale, ry = r[n + 1] * scale, rz = r[n + 2] * scale;
      T* qc = q + size_t(c) * 3 * W;
      qc[0 * W + l] = a0 * rx + a1 * ry + a2 * rz;
      qc[1 * W + l] = b0 * rx + b1 * ry + b2 * rz;
      qc[2 * W + l] = c0 * rx + c1 * ry + c2 * rz;
    }
  }
  T smallest = ratio[0];
  for (int l = 1; l < W; ++l) smallest = std::min(smallest, ratio[l]);
  return smallest;
}

// Corner forces of one block, f_c = D' q_c with D' = D0 + (u_j - u_0) the
// current edges, in the TLED kernel's layout.
template <typename T>
void ApplyBlock(const TledModel<T>& model, int b, const T* __restrict D0, const T* __restrict u,
                const T* __restrict q, T* __restrict f) {
  constexpr int W = TledModel<T>::kLanes;
  const int32_t* __restrict nodes = model.block_nodes(b);
  DG_LANE_LOOP
  for (int l = 0; l < W; ++l) {
    const int n0 = 3 * nodes[l], n1 = 3 * nodes[W + l], n2 = 3 * nodes[2 * W + l], n3 = 3 * nodes[3 * W + l];
    const EdgeMatrix<T> D(D0 + l, W, u, n0, n1, n2, n3);
    for (int c = 0; c < 4; ++c) {
      const T* qc = q + size_t(c) * 3 * W;
      const T q1 = qc[0 * W + l], q2 = qc[1 * W + l], q3 = qc[2 * W + l];
      T* fc = f + size_t(c) * 3 * W;
      fc[0 * W + l] = D.d1x * q1 + D.d2x * q2 + D.d3x * q3;
      fc[1 * W + l] = D.d1y * q1 + D.d2y * q2 + D.d3y * q3;
      fc[2 * W + l] = D.d1z * q1 + D.d2z * q2 + D.d3z * q3;
    }
  }
}

}  // namespace

template <typename T>
WorstElement FindWorstElement(const TetMesh& mesh, const T* u) {
  WorstElement worst{0, std::numeric_limits<double>::infinity()};
  for (int e = 0; e < mesh.num_tets(); ++e) {
    const double J = DeformationGradient(mesh, e, u).determinant();
    if (!(J >= worst.volume_ratio)) worst = {e, J};  // NaN counts as worst
  }
  return worst;
}

void ThrowDegenerateEdges(const TetMesh& mesh, const WorstElement& worst, double min_volume_ratio,
                          const std::string& when) {
  char ratio[96];
  std::snprintf(ratio, sizeof ratio, " (volume ratio %.3g, below %.3g) in ", worst.volume_ratio, min_volume_ratio);
  throw Error("degenerate edge triple: recovered forces cannot be resolved in this element's edges",
              ElementName(mesh, worst.element) + ratio + when,
              "check or smooth the preoperative motion there (its registration may fold the mesh)");
}

template <typename T>
ForceResolution<T>::ForceResolution(std::shared_ptr<const TledModel<T>> model) : model_(std::move(model)) {
  const TetMesh& mesh = model_->mesh();
  inverse_count_.resize(mesh.num_nodes());
  for (int a = 0; a < mesh.num_nodes(); ++a) {
    inverse_count_[a] = T(1) / static_cast<T>(model_->gather_begin()[a + 1] - model_->gather_begin()[a]);
  }
  corner_forces_.assign(model_->force_array_size(), T(0));
  chunk_min_ratio_.assign(model_->element_chunks(), T(1));
  layout_u_.resize(3 * size_t(mesh.num_nodes()));
  layout_forces_.resize(3 * size_t(mesh.num_nodes()));
}

template <typename T>
void ForceResolution<T>::Resolve(std::span<const T> u_model, std::span<const T> forces_n, std::span<T> weights) {
  const TledModel<T>& model = *model_;
  const size_t n_dofs = 3 * inverse_count_.size();
  DG_CHECK(u_model.size() == n_dofs && forces_n.size() == n_dofs && weights.size() == weights_size());
  constexpr int W = TledModel<T>::kLanes;
  model.ToLayout(u_model, std::span<T>(layout_u_));
  model.ToLayout(forces_n, std::span<T>(layout_forces_));
  ForEachBlockChunk(model, [&](int chunk, int begin, int end) {
    T smallest = T(1);
    for (int b = begin; b < end; ++b) {
      smallest = std::min(smallest, ResolveBlock(model, b, model.block_reference_edges(b), layout_u_.data(),
                                                 layout_forces_.data(), inverse_count_.data(),
                                                 weights.data() + size_t(b) * 12 * W));
    }
    chunk_min_ratio_[chunk] = smallest;
  });
  const T smallest = *std::min_element(chunk_min_ratio_.begin(), chunk_min_ratio_.end());
  if (!(smallest >= T(kMinVolumeRatio))) {
    ThrowDegenerateEdges(model.mesh(), FindWorstElement(model.mesh(), u_model.data()), kMinVolumeRatio,
                         "the motion model's geometry while running");
  }
}

template <typename T>
void ForceResolution<T>::Apply(std::span<const T> weights, std::span<const T> u, std::span<T> forces_n) {
  const TledModel<T>& model = *model_;
  const size_t n_dofs = 3 * inverse_count_.size();
  DG_CHECK(u.size() == n_dofs && forces_n.size() == n_dofs && weights.size() == weights_size());
  constexpr int W = TledModel<T>::kLanes;
  model.ToLayout(u, std::span<T>(layout_u_));
  ForEachBlockChunk(model, [&](int, int begin, int end) {
    for (int b = begin; b < end; ++b) {
      const size_t offset = size_t(b) * 12 * W;
      ApplyBlock(model, b, model.block_reference_edges(b), layout_u_.data(), weights.data() + offset,
                 corner_forces_.data() + offset);
    }
  });
  const int chunks = (model.num_nodes() + kNodesPerChunk - 1) / kNodesPerChunk;
  tbb::parallel_for(tbb::blocked_range<int>(0, chunks), [&](const tbb::blocked_range<int>& range) {
    for (int c = range.begin(); c != range.end(); ++c) {
      const int end = std::min((c + 1) * kNodesPerChunk, model.num_nodes());
      for (int a = c * kNodesPerChunk; a < end; ++a) {
        GatherNodalForce(model, corner_forces_.data(), a, &layout_forces_[3 * a]);
      }
    }
  });
  model.ToMeshOrder(std::span<const T>(layout_forces_), forces_n);
}

template <typename T>
void ForceResolution<T>::CheckGeometry(std::span<const T> u, const std::string& when) const {
  DG_CHECK(u.size() == 3 * inverse_count_.size());
  const WorstElement worst = FindWorstElement(model_->mesh(), u.data());
  if (!(worst.volume_ratio >= kMinVolumeRatio)) ThrowDegenerateEdges(model_->mesh(), worst, kMinVolumeRatio, when);
}

template WorstElement FindWorstElement<float>(const TetMesh&, const float*);
template WorstElement FindWorstElement<double>(const TetMesh&, const double*);
template class ForceResolution<float>;
template class ForceResolution<double>;

}  // namespace dg::sim
