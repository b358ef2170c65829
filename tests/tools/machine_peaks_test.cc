// The host-peak probe that every benchmark record carries: its kernels are
// checked against closed forms, so the operations it counts are the ones
// it did. The peaks themselves vary with the host; only their presence and
// sign are asserted (a weak check, said plainly: no time is asserted).
#include <sched.h>

#include <algorithm>
#include <cmath>
#include <thread>
#include <vector>

#include <catch2/catch.hpp>

#include "tools/bench/machine_peaks.h"

namespace dg::tools {
namespace {

TEST_CASE("machine peaks: the FMA chains compute x = x a + b, each lane of each chain", "[tools][unit]") {
  const int widest = FmaLanes();
  CHECK((widest == 16 || widest == 8 || widest == 1));
  for (const int lanes : {1, 8, 16}) {
    if (lanes > widest) continue;  // an instruction set this CPU lacks
    INFO(lanes << " lanes");
    std::vector<float> out(static_cast<size_t>(lanes) * kFmaChains);
    // a = 1, b = 2^-10: chain c ends at c + n / 1024, exact in float.
    RunFmaChains(lanes, 1.0f, 0x1p-10f, 1000, out.data());
    for (int c = 0; c < kFmaChains; ++c) {
      for (int l = 0; l < lanes; ++l) CHECK(out[c * lanes + l] == static_cast<float>(c) + 1000.0f / 1024.0f);
    }
    // a = 1/2, b = 1: x_n = 2 + (c - 2) / 2^n, exact for n = 3.
    RunFmaChains(lanes, 0.5f, 1.0f, 3, out.data());
    for (int c = 0; c < kFmaChains; ++c) {
      for (int l = 0; l < lanes; ++l) CHECK(out[c * lanes + l] == 2.0f + (static_cast<float>(c) - 2.0f) / 8.0f);
    }
  }
}

TEST_CASE("machine peaks: the triad writes a = b + s c on its range only", "[tools][unit]") {
  std::vector<double> a(10, -1.0), b(10), c(10);
  for (int i = 0; i < 10; ++i) {
    b[i] = i;
    c[i] = 0.5 * i;
  }
  Triad(a.data(), b.data(), c.data(), 4.0, 2, 7);
  for (int i = 0; i < 10; ++i) CHECK(a[i] == (i >= 2 && i < 7 ? 3.0 * i : -1.0));
}

TEST_CASE("machine peaks: the load/store kernel adds to every element once a pass", "[tools][unit]") {
  std::vector<float> a(37);
  for (int i = 0; i < 37; ++i) a[i] = static_cast<float>(i);
  AddInPlace(a.data(), 36, 0.25f, 8);  // the last element is outside the range
  for (int i = 0; i < 36; ++i) CHECK(a[i] == static_cast<float>(i) + 2.0f);
  CHECK(a[36] == 36.0f);
}

TEST_CASE("machine peaks: one figure a thread count, up to the cores", "[tools][unit]") {
  const MachinePeaks peaks = MeasureMachinePeaks(2);
  const size_t expected = std::thread::hardware_concurrency() >= 2 ? 2 : 1;
  REQUIRE(peaks.fma_fp32_gflops.size() == expected);
  REQUIRE(peaks.triad_gb_s.size() == expected);
  for (size_t t = 0; t < expected; ++t) {
    CHECK(std::isfinite(peaks.fma_fp32_gflops[t]));
    CHECK(peaks.fma_fp32_gflops[t] > 0);
    CHECK(std::isfinite(peaks.triad_gb_s[t]));
    CHECK(peaks.triad_gb_s[t] > 0);
  }
  // One figure a logical core, each measured on that core (NaN for one
  // outside the process's cpuset, where no thread can be pinned).
  REQUIRE(peaks.core_load_store_gb_s.size() == std::max(1u, std::thread::hardware_concurrency()));
  for (size_t core = 0; core < peaks.core_load_store_gb_s.size(); ++core) {
    INFO("core " << core);
    const double gb_s = peaks.core_load_store_gb_s[core];
    CHECK((std::isnan(gb_s) || gb_s > 0));
  }
  CHECK(peaks.core_load_store_gb_s[sched_getcpu()] > 0);  // a core this thread runs on
}

TEST_CASE("machine peaks: each core's figure in a table cell", "[tools][unit]") {
  CHECK(CoreLoadStoreText({327.4, 252.6}) == "327/253");
  CHECK(CoreLoadStoreText({std::nan(""), 10.0}) == "-/10");
  CHECK(CoreLoadStoreText({}) == "-");
}

TEST_CASE("machine peaks: a core the process may not run on has no load/store figure", "[tools][unit]") {
  CHECK(std::isnan(CoreLoadStoreGbPerS(CPU_SETSIZE - 1, std::chrono::milliseconds(1))));
}

}  // namespace
}  // namespace dg::tools
