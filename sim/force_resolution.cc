#include "sim/force_resolution.h"

#include <algorithm>
#include <cstdio>
#include <limits>

#include <Eigen/LU>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "sim/element_measures.h"
#include "sim/error.h"
#include "sim/tled_kernel.h"

namespace dg::sim {
namespace {

constexpr int kNodesPerChunk = 256;

// Runs body(first_block, end_block) for the model's fixed block chunks in parallel.
template <typename T, typename Body>
void ForEachBlockChunk(const TledModel<T>& model, Body body) {
  tbb::parallel_for(tbb::blocked_range<int>(0, ElementChunks(model)), [&](const tbb::blocked_range<int>& chunks) {
    for (int c = chunks.begin(); c != chunks.end(); ++c) {
      body(c, c * kBlocksPerChunk, std::min((c + 1) * kBlocksPerChunk, model.num_blocks()));
    }
  });
}

// Weights of one block: reads positions x = X + u and forces r scaled by 1/n_a;
// returns the block's smallest volume ratio det(D) / det(D_reference).
template <typename T>
T ResolveBlock(const TledModel<T>& model, int b, const T* __restrict X, const T* __restrict u,
               const T* __restrict r, const T* __restrict inverse_count, T* __restrict w) {
  constexpr int W = TledModel<T>::kLanes;
  const int32_t* __restrict nodes = model.block_nodes(b);
  const T* __restrict V0 = model.block_volumes(b);
  alignas(64) T ratio[W];
#pragma GCC ivdep
  for (int l = 0; l < W; ++l) {
    T p[4][3], rc[4][3];
    for (int c = 0; c < 4; ++c) {
      const int n = nodes[c * W + l];
      for (int i = 0; i < 3; ++i) {
        p[c][i] = X[3 * n + i] + u[3 * n + i];
        rc[c][i] = r[3 * n + i] * inverse_count[n];
      }
    }
    T d[3][3];  // d[j - 1] = x_j - x_0
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 3; ++i) d[j][i] = p[j + 1][i] - p[0][i];
    }
    // Rows of [d1 d2 d3]^-1 times det: d2 x d3, d3 x d1, d1 x d2.
    T row[3][3];
    for (int j = 0; j < 3; ++j) {
      const T* e = d[(j + 1) % 3];
      const T* f = d[(j + 2) % 3];
      row[j][0] = e[1] * f[2] - e[2] * f[1];
      row[j][1] = e[2] * f[0] - e[0] * f[2];
      row[j][2] = e[0] * f[1] - e[1] * f[0];
    }
    const T det = d[0][0] * row[0][0] + d[0][1] * row[0][1] + d[0][2] * row[0][2];
    const bool real = V0[l] > 0;  // padding lanes have no volume and no incidences
    ratio[l] = real ? det / (6 * V0[l]) : T(1);
    const T inv_det = real ? T(1) / det : T(0);
    for (int c = 0; c < 4; ++c) {
      T q[3];
      for (int j = 0; j < 3; ++j) q[j] = inv_det * (row[j][0] * rc[c][0] + row[j][1] * rc[c][1] + row[j][2] * rc[c][2]);
      // Edges to the other corners in increasing order: corner 0's are d1..d3;
      // corner c's edge to corner 0 carries -(q1 + q2 + q3), to corner j q_j.
      T* wc = w + size_t(c) * 3 * W;
      for (int k = 0; k < 3; ++k) {
        const int j = k < c ? k : k + 1;
        wc[k * W + l] = j == 0 ? -(q[0] + q[1] + q[2]) : q[j - 1];
      }
    }
  }
  T smallest = ratio[0];
  for (int l = 1; l < W; ++l) smallest = std::min(smallest, ratio[l]);
  return smallest;
}

// Corner forces of one block, sum_k w_k (x_{j_k} - x_c), in the TLED kernel's layout.
template <typename T>
void ApplyBlock(const TledModel<T>& model, int b, const T* __restrict X, const T* __restrict u,
                const T* __restrict w, T* __restrict f) {
  constexpr int W = TledModel<T>::kLanes;
  const int32_t* __restrict nodes = model.block_nodes(b);
#pragma GCC ivdep
  for (int l = 0; l < W; ++l) {
    T p[4][3];
    for (int c = 0; c < 4; ++c) {
      const int n = nodes[c * W + l];
      for (int i = 0; i < 3; ++i) p[c][i] = X[3 * n + i] + u[3 * n + i];
    }
    for (int c = 0; c < 4; ++c) {
      const T* wc = w + size_t(c) * 3 * W;
      T sum[3] = {0, 0, 0};
      for (int k = 0; k < 3; ++k) {
        const int j = k < c ? k : k + 1;
        for (int i = 0; i < 3; ++i) sum[i] += wc[k * W + l] * (p[j][i] - p[c][i]);
      }
      for (int i = 0; i < 3; ++i) f[(c * 3 + i) * W + l] = sum[i];
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

template <typename T>
ForceResolution<T>::ForceResolution(std::shared_ptr<const TledModel<T>> model) : model_(std::move(model)) {
  const TetMesh& mesh = model_->mesh();
  X_.resize(3 * size_t(mesh.num_nodes()));
  for (int a = 0; a < mesh.num_nodes(); ++a) {
    for (int i = 0; i < 3; ++i) X_[3 * a + i] = static_cast<T>(mesh.X_m(i, a));
  }
  inverse_count_.resize(mesh.num_nodes());
  for (int a = 0; a < mesh.num_nodes(); ++a) {
    inverse_count_[a] = T(1) / static_cast<T>(model_->gather_begin()[a + 1] - model_->gather_begin()[a]);
  }
  corner_forces_.assign(model_->force_array_size(), T(0));
  chunk_min_ratio_.assign(ElementChunks(*model_), T(1));
}

template <typename T>
void ForceResolution<T>::Resolve(std::span<const T> u_model, std::span<const T> forces_n, std::span<T> weights) {
  const TledModel<T>& model = *model_;
  DG_CHECK(u_model.size() == X_.size() && forces_n.size() == X_.size() && weights.size() == weights_size());
  ForEachBlockChunk(model, [&](int chunk, int begin, int end) {
    T smallest = T(1);
    for (int b = begin; b < end; ++b) {
      smallest = std::min(smallest, ResolveBlock(model, b, X_.data(), u_model.data(), forces_n.data(),
                                                 inverse_count_.data(), weights.data() + size_t(b) * 12 * model.kLanes));
    }
    chunk_min_ratio_[chunk] = smallest;
  });
  const T smallest = *std::min_element(chunk_min_ratio_.begin(), chunk_min_ratio_.end());
  if (!(smallest >= T(kMinVolumeRatio))) {
    ThrowDegenerate(FindWorstElement(model.mesh(), u_model.data()), "the motion model's geometry while running");
  }
}

template <typename T>
void ForceResolution<T>::Apply(std::span<const T> weights, std::span<const T> u, std::span<T> forces_n) {
  const TledModel<T>& model = *model_;
  DG_CHECK(u.size() == X_.size() && forces_n.size() == X_.size() && weights.size() == weights_size());
  ForEachBlockChunk(model, [&](int, int begin, int end) {
    for (int b = begin; b < end; ++b) {
      const size_t offset = size_t(b) * 12 * model.kLanes;
      ApplyBlock(model, b, X_.data(), u.data(), weights.data() + offset, corner_forces_.data() + offset);
    }
  });
  const int chunks = (model.num_nodes() + kNodesPerChunk - 1) / kNodesPerChunk;
  tbb::parallel_for(tbb::blocked_range<int>(0, chunks), [&](const tbb::blocked_range<int>& range) {
    for (int c = range.begin(); c != range.end(); ++c) {
      const int end = std::min((c + 1) * kNodesPerChunk, model.num_nodes());
      for (int a = c * kNodesPerChunk; a < end; ++a) GatherNodalForce(model, corner_forces_.data(), a, &forces_n[3 * a]);
    }
  });
}

template <typename T>
void ForceResolution<T>::CheckGeometry(std::span<const T> u, const std::string& when) const {
  DG_CHECK(u.size() == X_.size());
  const WorstElement worst = FindWorstElement(model_->mesh(), u.data());
  if (!(worst.volume_ratio >= kMinVolumeRatio)) ThrowDegenerate(worst, when);
}

template <typename T>
void ForceResolution<T>::ThrowDegenerate(const WorstElement& worst, const std::string& when) const {
  char where[160];
  std::snprintf(where, sizeof where, "element %d (volume ratio %.3g, below %.3g) in %s", worst.element,
                worst.volume_ratio, kMinVolumeRatio, when.c_str());
  throw Error("degenerate edge triple: recovered forces cannot be resolved in this element's edges", where,
              "check or smooth the preoperative motion there (its registration may fold the mesh)");
}

template WorstElement FindWorstElement<float>(const TetMesh&, const float*);
template WorstElement FindWorstElement<double>(const TetMesh&, const double*);
template class ForceResolution<float>;
template class ForceResolution<double>;

}  // namespace dg::sim
