#include "sim/tled_kernel.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>
#include <type_traits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include "sim/corner_loads.h"
#include "sim/lane_loop.h"

namespace dg::sim {

template <typename T>
T InverseCubeRoot(T x) {
  // Guess in float: for x = 2^e (1 + m) the bit pattern is about (e + 127 + m) 2^23,
  // so 4/3 * 127 * 2^23 - bits/3 is roughly the pattern of x^(-1/3) (Lomont's trick
  // for the cube root). The division is done in float to stay vectorisable; its
  // rounding only perturbs the guess.
  const float xf = static_cast<float>(x);
  const int32_t bits = std::bit_cast<int32_t>(xf);
  const int32_t guess_bits = 0x54a2fa8c - static_cast<int32_t>(static_cast<float>(bits) * (1.0f / 3.0f));
  T y = static_cast<T>(std::bit_cast<float>(guess_bits));
  // The guess is within 4%; error 0.04 -> 3e-3 -> 2e-5 -> 8e-10 -> 1e-18.
  constexpr int kIterations = sizeof(T) == 4 ? 3 : 4;
  for (int i = 0; i < kIterations; ++i) y = y * (T(4) - x * y * y * y) * T(1.0 / 3.0);
  return y;
}

namespace {

// What the element pass does besides the internal forces (see tled_kernel.h).
enum class PassMode { kForces, kLessLoads, kLessBlendedLoads, kResolve };

// The element pass over blocks [block_begin, block_end); `loads` (kLessLoads:
// its first; kLessBlendedLoads: all) and `resolve` (kResolve) are used in
// their mode only. Returns the smallest J.
template <typename T, PassMode kMode>
T ElementPass(const TledModel<T>& model, const T* __restrict u, T* __restrict forces, int block_begin,
              int block_end, const ElementLoads<T>* loads, ResolveBuffers<T>* resolve) {
  constexpr bool kWithLoads = kMode == PassMode::kLessLoads || kMode == PassMode::kLessBlendedLoads;
  constexpr int W = TledModel<T>::kLanes;
  const T mu = model.shear_modulus();
  const T kappa = model.bulk_modulus();
  T min_J = std::numeric_limits<T>::max();
  T* __restrict edge_inverse = kMode == PassMode::kResolve ? resolve->edge_inverse : nullptr;
  const T* __restrict scaled_forces = kMode == PassMode::kResolve ? resolve->scaled_forces_n : nullptr;
  T* __restrict weights = kMode == PassMode::kResolve ? resolve->weights : nullptr;

  for (int b = block_begin; b < block_end; ++b) {
    const int32_t* __restrict nodes = model.block_nodes(b);
    const T* __restrict dN = model.block_shape_gradients(b);
    const T* __restrict V0 = model.block_volumes(b);
    const T* __restrict D0 = model.block_reference_edges(b);
    T* __restrict f = forces + size_t(b) * 12 * W;
    const T* __restrict q_first = kWithLoads ? loads->first + size_t(b) * 12 * W : nullptr;
    const T* __restrict q_second =
        kMode == PassMode::kLessBlendedLoads ? loads->second + size_t(b) * 12 * W : nullptr;
    T* __restrict Dinv = kMode == PassMode::kResolve ? edge_inverse + size_t(b) * 9 * W : nullptr;
    T* __restrict q_out = kMode == PassMode::kResolve ? weights + size_t(b) * 12 * W : nullptr;
    alignas(64) T J_lane[W];
    // The corners' displacements, [corner][xyz][lane], loaded for the whole
    // block where that is faster than the lane loop's gathers (corner_loads.h).
    constexpr bool kCornersLoaded = kCornerLoadsTransposed && std::is_same_v<T, float>;
    static_assert(!kCornersLoaded || W == 16, "LoadCornerDisplacements fills 16-lane blocks");
    alignas(64) T corners[kCornersLoaded ? 12 * W : 1];
    if constexpr (kCornersLoaded) LoadCornerDisplacements(nodes, u, corners);

    DG_LANE_LOOP
    for (int l = 0; l < W; ++l) {
      // Component `axis` of corner c's displacement.
      auto at = [&](int c, int axis) {
        if constexpr (kCornersLoaded) {
          return corners[(3 * c + axis) * W + l];
        } else {
          return u[3 * nodes[c * W + l] + axis];
        }
      };
      // Edge displacements d_c = u_c - u_0 (c = 1..3): since dN0 = -(dN1 + dN2 + dN3),
      // sum_a u_a (x) dN_a = sum_c d_c (x) dN_c.
      const T d1x = at(1, 0) - at(0, 0), d1y = at(1, 1) - at(0, 1), d1z = at(1, 2) - at(0, 2);
      const T d2x = at(2, 0) - at(0, 0), d2y = at(2, 1) - at(0, 1), d2z = at(2, 2) - at(0, 2);
      const T d3x = at(3, 0) - at(0, 0), d3y = at(3, 1) - at(0, 1), d3z = at(3, 2) - at(0, 2);
      const T g1x = dN[0 * W + l], g1y = dN[1 * W + l], g1z = dN[2 * W + l];
      const T g2x = dN[3 * W + l], g2y = dN[4 * W + l], g2z = dN[5 * W + l];
      const T g3x = dN[6 * W + l], g3y = dN[7 * W + l], g3z = dN[8 * W + l];

      // Deformation gradient F_ij = delta_ij + sum_c d_ci g_cj.
      const T F00 = 1 + d1x * g1x + d2x * g2x + d3x * g3x;
      const T F01 = d1x * g1y + d2x * g2y + d3x * g3y;
      const T F02 = d1x * g1z + d2x * g2z + d3x * g3z;
      const T F10 = d1y * g1x + d2y * g2x + d3y * g3x;
      const T F11 = 1 + d1y * g1y + d2y * g2y + d3y * g3y;
      const T F12 = d1y * g1z + d2y * g2z + d3y * g3z;
      const T F20 = d1z * g1x + d2z * g2x + d3z * g3x;
      const T F21 = d1z * g1y + d2z * g2y + d3z * g3y;
      const T F22 = 1 + d1z * g1z + d2z * g2z + d3z * g3z;

      // P = F S with S = a I + s C^-1 (a = mu J^(-2/3), s = kappa J (J - 1) - a tr(C)/3)
      // is P = a F + (s / J) cof(F), since F C^-1 = F^-T = cof(F) / J: the same
      // stress without forming C, its inverse or the product F S (half the flops).
      const T cof00 = F11 * F22 - F12 * F21, cof01 = F12 * F20 - F10 * F22, cof02 = F10 * F21 - F11 * F20;
      const T cof10 = F02 * F21 - F01 * F22, cof11 = F00 * F22 - F02 * F20, cof12 = F01 * F20 - F00 * F21;
      const T cof20 = F01 * F12 - F02 * F11, cof21 = F02 * F10 - F00 * F12, cof22 = F00 * F11 - F01 * F10;
      const T J = F00 * cof00 + F01 * cof01 + F02 * cof02;
      const T trace_C = F00 * F00 + F01 * F01 + F02 * F02 + F10 * F10 + F11 * F11 + F12 * F12 + F20 * F20 +
                        F21 * F21 + F22 * F22;
      const T a = mu * InverseCubeRoot(J * J);
      const T s = kappa * J * (J - 1) - a * trace_C * T(1.0 / 3.0);
      // Scaled by the element volume, as the nodal forces need V0 P.
      const T v = V0[l];
      const T va = v * a, vs = v * s / J;
      const T P00 = va * F00 + vs * cof00, P01 = va * F01 + vs * cof01, P02 = va * F02 + vs * cof02;
      const T P10 = va * F10 + vs * cof10, P11 = va * F11 + vs * cof11, P12 = va * F12 + vs * cof12;
      const T P20 = va * F20 + vs * cof20, P21 = va * F21 + vs * cof21, P22 = va * F22 + vs * cof22;

      // f_c = V0 P dN_c; corner 0 balances the other three.
      T f1x = P00 * g1x + P01 * g1y + P02 * g1z;
      T f1y = P10 * g1x + P11 * g1y + P12 * g1z;
      T f1z = P20 * g1x + P21 * g1y + P22 * g1z;
      T f2x = P00 * g2x + P01 * g2y + P02 * g2z;
      T f2y = P10 * g2x + P11 * g2y + P12 * g2z;
      T f2z = P20 * g2x + P21 * g2y + P22 * g2z;
      T f3x = P00 * g3x + P01 * g3y + P02 * g3z;
      T f3y = P10 * g3x + P11 * g3y + P12 * g3z;
      T f3z = P20 * g3x + P21 * g3y + P22 * g3z;
      T f0x = -(f1x + f2x + f3x), f0y = -(f1y + f2y + f3y), f0z = -(f1z + f2z + f3z);

      if constexpr (kWithLoads) {
        // The current edges D = D0 + (u_j - u_0), columns e1, e2, e3.
        const T e1x = D0[0 * W + l] + d1x, e1y = D0[1 * W + l] + d1y, e1z = D0[2 * W + l] + d1z;
        const T e2x = D0[3 * W + l] + d2x, e2y = D0[4 * W + l] + d2y, e2z = D0[5 * W + l] + d2z;
        const T e3x = D0[6 * W + l] + d3x, e3y = D0[7 * W + l] + d3y, e3z = D0[8 * W + l] + d3z;
        // Corner c's resolved load D q_c (eq. 5 in the current geometry), taken off its force.
        auto weight = [&](int k) {
          if constexpr (kMode == PassMode::kLessBlendedLoads) {
            return q_first[k * W + l] + loads->blend * (q_second[k * W + l] - q_first[k * W + l]);
          } else {
            return q_first[k * W + l];
          }
        };
        auto load = [&](int c, T& fx, T& fy, T& fz) {
          const T q1 = weight(3 * c), q2 = weight(3 * c + 1), q3 = weight(3 * c + 2);
          fx -= e1x * q1 + e2x * q2 + e3x * q3;
          fy -= e1y * q1 + e2y * q2 + e3y * q3;
          fz -= e1z * q1 + e2z * q2 + e3z * q3;
        };
        load(0, f0x, f0y, f0z);
        load(1, f1x, f1y, f1z);
        load(2, f2x, f2y, f2z);
        load(3, f3x, f3y, f3z);
      } else if constexpr (kMode == PassMode::kResolve) {
        // Resolve the previous level's forces with its D^-1 (rows stored in Dinv),
        // q_c = D^-1 (r_c / n_c), then store this geometry's D^-1 in its place.
        const T r00 = Dinv[0 * W + l], r01 = Dinv[1 * W + l], r02 = Dinv[2 * W + l];
        const T r10 = Dinv[3 * W + l], r11 = Dinv[4 * W + l], r12 = Dinv[5 * W + l];
        const T r20 = Dinv[6 * W + l], r21 = Dinv[7 * W + l], r22 = Dinv[8 * W + l];
        for (int c = 0; c < 4; ++c) {
          const int n = 3 * nodes[c * W + l];
          const T rx = scaled_forces[n], ry = scaled_forces[n + 1], rz = scaled_forces[n + 2];
          q_out[(3 * c) * W + l] = r00 * rx + r01 * ry + r02 * rz;
          q_out[(3 * c + 1) * W + l] = r10 * rx + r11 * ry + r12 * rz;
          q_out[(3 * c + 2) * W + l] = r20 * rx + r21 * ry + r22 * rz;
        }
        // This geometry's D^-1 = D0^-1 F^-1: D = F D0, the rows of D0^-1 are
        // dN_c/dX (c = 1..3) and F^-1 = cof(F)^T / J, so row c, column k is
        // (dN_c/dX . row k of cof(F)) / J. Its volume ratio det(D)/det(D0) is J.
        // Padding lanes have dN = 0 and J = 1: zero rows, ratio 1.
        const T inv_J = T(1) / J;
        const T k0x = cof00 * inv_J, k0y = cof01 * inv_J, k0z = cof02 * inv_J;
        const T k1x = cof10 * inv_J, k1y = cof11 * inv_J, k1z = cof12 * inv_J;
        const T k2x = cof20 * inv_J, k2y = cof21 * inv_J, k2z = cof22 * inv_J;
        Dinv[0 * W + l] = g1x * k0x + g1y * k0y + g1z * k0z;
        Dinv[1 * W + l] = g1x * k1x + g1y * k1y + g1z * k1z;
        Dinv[2 * W + l] = g1x * k2x + g1y * k2y + g1z * k2z;
        Dinv[3 * W + l] = g2x * k0x + g2y * k0y + g2z * k0z;
        Dinv[4 * W + l] = g2x * k1x + g2y * k1y + g2z * k1z;
        Dinv[5 * W + l] = g2x * k2x + g2y * k2y + g2z * k2z;
        Dinv[6 * W + l] = g3x * k0x + g3y * k0y + g3z * k0z;
        Dinv[7 * W + l] = g3x * k1x + g3y * k1y + g3z * k1z;
        Dinv[8 * W + l] = g3x * k2x + g3y * k2y + g3z * k2z;
      }
      f[0 * W + l] = f0x;
      f[1 * W + l] = f0y;
      f[2 * W + l] = f0z;
      f[3 * W + l] = f1x;
      f[4 * W + l] = f1y;
      f[5 * W + l] = f1z;
      f[6 * W + l] = f2x;
      f[7 * W + l] = f2y;
      f[8 * W + l] = f2z;
      f[9 * W + l] = f3x;
      f[10 * W + l] = f3y;
      f[11 * W + l] = f3z;
      J_lane[l] = J;
    }
    for (int l = 0; l < W; ++l) min_J = std::min(min_J, J_lane[l]);
  }
  if constexpr (kMode == PassMode::kResolve) resolve->min_volume_ratio = min_J;
  return min_J;
}

}  // namespace

template <typename T>
T ComputeElementForces(const TledModel<T>& model, const T* u, T* forces, int block_begin, int block_end) {
  return ElementPass<T, PassMode::kForces>(model, u, forces, block_begin, block_end, nullptr, nullptr);
}

template <typename T>
T ComputeElementForcesLessLoads(const TledModel<T>& model, const T* u, const ElementLoads<T>& loads, T* forces,
                                int block_begin, int block_end) {
  if (loads.second == nullptr || loads.blend == T(0)) {
    return ElementPass<T, PassMode::kLessLoads>(model, u, forces, block_begin, block_end, &loads, nullptr);
  }
  return ElementPass<T, PassMode::kLessBlendedLoads>(model, u, forces, block_begin, block_end, &loads, nullptr);
}

template <typename T>
T ComputeElementForcesAndResolve(const TledModel<T>& model, const T* u, ResolveBuffers<T>* resolve, T* forces,
                                 int block_begin, int block_end) {
  return ElementPass<T, PassMode::kResolve>(model, u, forces, block_begin, block_end, nullptr, resolve);
}

template <typename T>
void ComputeElementForcesParallel(const TledModel<T>& model, const T* u, T* forces, std::span<T> chunk_min_J) {
  // TBB's auto partitioner hands the chunks out, so a thread that the machine
  // delays (a shared virtual core) takes fewer of them instead of holding up the step.
  tbb::parallel_for(
      tbb::blocked_range<int>(0, static_cast<int>(chunk_min_J.size())),
      [&](const tbb::blocked_range<int>& chunks) {
        for (int c = chunks.begin(); c != chunks.end(); ++c) {
          chunk_min_J[c] = ComputeElementForces(model, u, forces, model.chunk_block_begin(c),
                                                model.chunk_block_begin(c + 1));
        }
      },
      tbb::auto_partitioner());
}

namespace {

// For a model of as many parts as workers: each part's node chunks in the
// order in which the part's element chunks complete their forces, and how
// many of those element chunks each reads. Elements are sorted by their
// first layout node, so a node's forces are complete soon after the
// elements it comes first in, and a chunk's gather finds most of its
// forces in the core's nearest caches (docs/solver.md, "Threads").
template <typename T>
StepTeam::ThenOrder NodeChunkOrder(const TledModel<T>& model, const ChunkHomes& homes) {
  constexpr int kForcesPerBlock = 12 * TledModel<T>::kLanes;
  std::vector<int> chunk_of_block(model.chunk_block_begin(model.element_chunks()));
  for (int c = 0; c < model.element_chunks(); ++c) {
    std::fill(chunk_of_block.begin() + model.chunk_block_begin(c),
              chunk_of_block.begin() + model.chunk_block_begin(c + 1), c);
  }
  StepTeam::ThenOrder order{true, {}, {}};
  std::vector<int> needs(NodeChunks(model), 0);
  for (size_t part = 0; part + 1 < homes.nodes.size(); ++part) {
    for (int chunk = homes.nodes[part]; chunk < homes.nodes[part + 1]; ++chunk) {
      const int end = std::min((chunk + 1) * kNodesPerChunk, model.num_nodes());
      for (int k = model.gather_begin()[chunk * kNodesPerChunk]; k < model.gather_begin()[end]; ++k) {
        const int element_chunk = chunk_of_block[model.gather_offsets()[k] / kForcesPerBlock];
        DG_CHECK(element_chunk >= homes.elements[part] && element_chunk < homes.elements[part + 1]);
        needs[chunk] = std::max(needs[chunk], element_chunk + 1 - homes.elements[part]);
      }
      order.order.push_back(chunk);
    }
    std::stable_sort(order.order.begin() + homes.nodes[part], order.order.end(),
                     [&](int a, int b) { return needs[a] < needs[b]; });
  }
  for (int chunk : order.order) order.needs.push_back(needs[chunk]);
  return order;
}

}  // namespace

template <typename T>
ChunkHomes PartitionChunks(const TledModel<T>& model, int parts) {
  constexpr int W = TledModel<T>::kLanes;
  if (model.parts() == parts) {
    ChunkHomes homes;
    homes.elements.assign(model.part_chunk_begin().begin(), model.part_chunk_begin().end());
    for (int node : model.part_node_begin()) homes.nodes.push_back((node + kNodesPerChunk - 1) / kNodesPerChunk);
    homes.node_order = NodeChunkOrder(model, homes);
    return homes;
  }
  const int element_chunks = model.element_chunks(), node_chunks = NodeChunks(model);
  // The first (smallest) layout node of the element in `slot`: the sort key.
  auto first_node = [&](int slot) {
    const int32_t* nodes = model.block_nodes(slot / W);
    const int lane = slot % W;
    return std::min({nodes[lane], nodes[W + lane], nodes[2 * W + lane], nodes[3 * W + lane]});
  };
  ChunkHomes homes{{0}, {0}, {}};
  for (int w = 1; w < parts; ++w) {
    const int middle_slot = static_cast<int>(std::int64_t(model.num_tets()) * w / parts);
    const int node_chunk = std::clamp((first_node(middle_slot) + kNodesPerChunk / 2) / kNodesPerChunk,
                                      homes.nodes.back(), node_chunks);
    int element_chunk = homes.elements.back();
    while (element_chunk < element_chunks &&
           first_node(model.chunk_block_begin(element_chunk) * W) < node_chunk * kNodesPerChunk) {
      ++element_chunk;
    }
    homes.nodes.push_back(node_chunk);
    homes.elements.push_back(element_chunk);
  }
  homes.nodes.push_back(node_chunks);
  homes.elements.push_back(element_chunks);
  return homes;
}

template ChunkHomes PartitionChunks<float>(const TledModel<float>&, int);
template ChunkHomes PartitionChunks<double>(const TledModel<double>&, int);
template float InverseCubeRoot<float>(float);
template double InverseCubeRoot<double>(double);
template float ComputeElementForces<float>(const TledModel<float>&, const float*, float*, int, int);
template float ComputeElementForcesLessLoads<float>(const TledModel<float>&, const float*, const ElementLoads<float>&,
                                                    float*, int, int);
template double ComputeElementForcesLessLoads<double>(const TledModel<double>&, const double*,
                                                      const ElementLoads<double>&, double*, int, int);
template float ComputeElementForcesAndResolve<float>(const TledModel<float>&, const float*, ResolveBuffers<float>*,
                                                     float*, int, int);
template double ComputeElementForcesAndResolve<double>(const TledModel<double>&, const double*,
                                                       ResolveBuffers<double>*, double*, int, int);
template double ComputeElementForces<double>(const TledModel<double>&, const double*, double*, int,
                                             int);
template void ComputeElementForcesParallel<float>(const TledModel<float>&, const float*, float*, std::span<float>);
template void ComputeElementForcesParallel<double>(const TledModel<double>&, const double*, double*,
                                                   std::span<double>);

}  // namespace dg::sim
