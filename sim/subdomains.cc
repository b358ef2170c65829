#include "sim/subdomains.h"

#include <algorithm>
#include <cstdint>
#include <numeric>

#include "sim/error.h"

namespace dg::sim {

Subdomains SplitIntoSubdomains(const TetMesh& mesh, int parts, int node_granularity) {
  DG_CHECK(parts >= 1 && node_granularity >= 1);
  const int N = mesh.num_nodes(), E = mesh.num_tets();
  const int granules = (N + node_granularity - 1) / node_granularity;
  parts = std::clamp(parts, 1, std::max(granules, 1));

  std::vector<int> smallest(E), largest(E);
  for (int e = 0; e < E; ++e) {
    smallest[e] = mesh.tets.col(e).minCoeff();
    largest[e] = mesh.tets.col(e).maxCoeff();
  }
  std::vector<int> sorted_smallest = smallest, sorted_largest = largest;
  std::sort(sorted_smallest.begin(), sorted_smallest.end());
  std::sort(sorted_largest.begin(), sorted_largest.end());
  // About the elements of the part with nodes [first, end): those whose
  // smallest node is below end and whose largest is at or above first (an
  // element spanning the whole range without a node in it is counted too).
  // Elements with smallest node >= end have largest >= first, so the count is
  // a difference of two ranks.
  auto count = [&](int first, int end) {
    const auto below = [](const std::vector<int>& sorted, int node) {
      return std::lower_bound(sorted.begin(), sorted.end(), node) - sorted.begin();
    };
    return static_cast<std::int64_t>(below(sorted_smallest, end) - below(sorted_largest, first));
  };

  // The bounds that make the largest part smallest: for a size S, cut each
  // part as late as keeps it within S; the smallest S for which the last part
  // fits is found by bisection (a part's size grows with its end).
  auto cut = [&](std::int64_t size) {
    std::vector<int> bounds = {0};
    for (int w = 1; w < parts; ++w) {
      const int first = bounds.back();
      int end_granule = first / node_granularity + 1;  // at least one granule a part
      while (end_granule + 1 <= granules - (parts - w) &&
             count(first, (end_granule + 1) * node_granularity) <= size) {
        ++end_granule;
      }
      bounds.push_back(end_granule * node_granularity);
    }
    bounds.push_back(N);
    return bounds;
  };
  std::int64_t low = (E + parts - 1) / parts, high = E;  // high always fits
  while (low < high) {
    const std::int64_t size = low + (high - low) / 2;
    const std::vector<int> bounds = cut(size);
    if (count(bounds[parts - 1], N) <= size) {
      high = size;
    } else {
      low = size + 1;
    }
  }
  Subdomains split;
  split.node_begin = cut(high);

  // Each part's elements in order of their smallest node (then of their id),
  // so that a block of neighbouring lanes shares nodes: the interior, then the halo.
  split.order.resize(E);
  std::iota(split.order.begin(), split.order.end(), 0);
  std::stable_sort(split.order.begin(), split.order.end(),
                   [&](int a, int b) { return smallest[a] < smallest[b]; });
  split.elements.resize(parts);
  for (int w = 0; w < parts; ++w) {
    const int first = split.node_begin[w], end = split.node_begin[w + 1];
    std::vector<int> halo;
    for (int e : split.order) {
      if (smallest[e] >= end || largest[e] < first) continue;
      int owned = 0;
      for (int c = 0; c < 4; ++c) owned += mesh.tets(c, e) >= first && mesh.tets(c, e) < end;
      if (owned == 4) {
        split.elements[w].push_back(e);
      } else if (owned > 0) {
        halo.push_back(e);
      }
    }
    split.elements[w].insert(split.elements[w].end(), halo.begin(), halo.end());
  }
  return split;
}

}  // namespace dg::sim
