#pragma once

#include <cstdint>

#if defined(__AVX512F__) && defined(__AVX512VL__)
#include <immintrin.h>
#endif

namespace dg::sim {

// The element pass reads the displacements of its blocks' corner nodes, 12
// values a lane. Left to the compiler these are twelve 16-lane gathers a
// block, which make up some 60% of the pass on AVX-512 machines (a gather
// fetches its lanes one by one); loading each node's x, y, z as one short
// vector and transposing four of them at a time in registers does the same
// work in about 40% of the time (docs/solver.md, "Stress and update").
#if defined(__AVX512F__) && defined(__AVX512VL__)
constexpr bool kCornerLoadsTransposed = true;

// corners[(3 c + axis) * 16 + l] = u[3 nodes[c * 16 + l] + axis] for the 4
// corners and 16 lanes of a float block ([corner][lane] node ids, u 3 per node).
// Reads only those nodes' three values (masked loads): safe at the array's end.
inline void LoadCornerDisplacements(const int32_t* __restrict nodes, const float* __restrict u,
                                    float* __restrict corners) {
  for (int c = 0; c < 4; ++c) {
    const int32_t* corner = nodes + 16 * c;
    auto node = [&](int lane) { return _mm_maskz_loadu_ps(0x7, u + 3 * corner[lane]); };
    // quads[i] holds, in its 128-bit part j, the (x, y, z, 0) of lane 4 j + i,
    // so that the in-part transpose below leaves lane l at position l.
    __m512 quads[4];
    for (int i = 0; i < 4; ++i) {
      __m512 quad = _mm512_castps128_ps512(node(i));
      quad = _mm512_insertf32x4(quad, node(4 + i), 1);
      quad = _mm512_insertf32x4(quad, node(8 + i), 2);
      quads[i] = _mm512_insertf32x4(quad, node(12 + i), 3);
    }
    const __m512 xy01 = _mm512_unpacklo_ps(quads[0], quads[1]);  // per part: x0 x1 y0 y1
    const __m512 xy23 = _mm512_unpacklo_ps(quads[2], quads[3]);  // x2 x3 y2 y3
    const __m512 z01 = _mm512_unpackhi_ps(quads[0], quads[1]);   // z0 z1 0 0
    const __m512 z23 = _mm512_unpackhi_ps(quads[2], quads[3]);   // z2 z3 0 0
    _mm512_store_ps(corners + (3 * c) * 16, _mm512_shuffle_ps(xy01, xy23, 0x44));
    _mm512_store_ps(corners + (3 * c + 1) * 16, _mm512_shuffle_ps(xy01, xy23, 0xEE));
    _mm512_store_ps(corners + (3 * c + 2) * 16, _mm512_shuffle_ps(z01, z23, 0x44));
  }
}
#else
constexpr bool kCornerLoadsTransposed = false;
#endif

}  // namespace dg::sim
