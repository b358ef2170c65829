#include "tools/bench/machine_peaks.h"

#include <immintrin.h>
#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <thread>

#include "sim/error.h"
#include "tools/bench/run_together.h"

namespace dg::tools {
namespace {

using Clock = std::chrono::steady_clock;

// One kernel per instruction set, each compiled for its own target so that
// the probe measures the CPU's widest FMA whatever the build's -march. A
// macro, not a template: an intrinsic can only be called from a function
// compiled for its target, and a target cannot be a template argument.
#define DG_FMA_CHAINS(name, isa, Vector, set1, fmadd, storeu, lanes)                          \
  __attribute__((target(isa))) void name(float a, float b, long iterations, float* out) {    \
    const Vector va = set1(a), vb = set1(b);                                                 \
    Vector x[kFmaChains];                                                                    \
    for (int c = 0; c < kFmaChains; ++c) x[c] = set1(static_cast<float>(c));                 \
    for (long i = 0; i < iterations; ++i) {                                                  \
      _Pragma("GCC unroll 12") for (int c = 0; c < kFmaChains; ++c) x[c] = fmadd(x[c], va, vb); \
    }                                                                                        \
    for (int c = 0; c < kFmaChains; ++c) storeu(out + (lanes) * c, x[c]);                    \
  }
DG_FMA_CHAINS(FmaAvx512, "avx512f", __m512, _mm512_set1_ps, _mm512_fmadd_ps, _mm512_storeu_ps, 16)
DG_FMA_CHAINS(FmaAvx2, "avx2,fma", __m256, _mm256_set1_ps, _mm256_fmadd_ps, _mm256_storeu_ps, 8)
#undef DG_FMA_CHAINS

void FmaScalar(float a, float b, long iterations, float* out) {
  float x[kFmaChains];
  for (int c = 0; c < kFmaChains; ++c) x[c] = static_cast<float>(c);
  for (long i = 0; i < iterations; ++i) {
    for (int c = 0; c < kFmaChains; ++c) x[c] = std::fma(x[c], a, b);
  }
  std::copy(x, x + kFmaChains, out);
}

// The wall time of work(thread) on `threads` threads released together,
// until the last finishes, in seconds.
template <typename Work>
double TimeTogether(int threads, const Work& work) {
  const Clock::time_point start = RunTogether(threads, [&](int t, Clock::time_point) { work(t); });
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// The best of `repeats` timings: the others met an interruption.
template <typename Measure>
double Best(int repeats, const Measure& measure) {
  double best = 0;
  for (int r = 0; r < repeats; ++r) best = std::max(best, measure());
  return best;
}

double FmaGflops(int threads) {
  constexpr long kIterations = 20'000'000;  // about 0.1 s a thread at 100 GFLOP/s
  const int lanes = FmaLanes();
  std::vector<std::vector<float>> out(threads, std::vector<float>(lanes * kFmaChains));
  return Best(2, [&] {
    // b of 2^-30 keeps the values small and normal for any iteration count.
    const double seconds =
        TimeTogether(threads, [&](int t) { RunFmaChains(lanes, 1.0f, 0x1p-30f, kIterations, out[t].data()); });
    return 2.0 * lanes * kFmaChains * kIterations * threads / seconds * 1e-9;
  });
}

// Three arrays far larger than the caches, kept for every thread count:
// allocating and touching them again for each would cost 24,000 page faults.
struct TriadArrays {
  static constexpr long kElements = 4L << 20;  // 32 MiB an array
  std::unique_ptr<double[]> a{new double[kElements]}, b{new double[kElements]}, c{new double[kElements]};
  TriadArrays() {
    std::fill(a.get(), a.get() + kElements, 0.0);
    std::fill(b.get(), b.get() + kElements, 1.0);
    std::fill(c.get(), c.get() + kElements, 2.0);
  }
};

double TriadGbPerS(int threads, TriadArrays& arrays) {
  constexpr long n = TriadArrays::kElements;
  return Best(3, [&] {
    const double seconds = TimeTogether(threads, [&](int t) {
      Triad(arrays.a.get(), arrays.b.get(), arrays.c.get(), 3.0, n * t / threads, n * (t + 1) / threads);
    });
    return 24.0 * n / seconds * 1e-9;
  });
}

}  // namespace

int FmaLanes() {
  if (__builtin_cpu_supports("avx512f")) return 16;
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return 8;
  return 1;
}

void RunFmaChains(int lanes, float a, float b, long iterations, float* out) {
  DG_CHECK(lanes == 1 || ((lanes == 8 || lanes == 16) && lanes <= FmaLanes()));
  switch (lanes) {
    case 16:
      FmaAvx512(a, b, iterations, out);
      return;
    case 8:
      FmaAvx2(a, b, iterations, out);
      return;
    default:
      FmaScalar(a, b, iterations, out);
  }
}

void Triad(double* a, const double* b, const double* c, double s, long begin, long end) {
  for (long i = begin; i < end; ++i) a[i] = b[i] + s * c[i];
}

void AddInPlace(float* a, long n, float s, long passes) {
  for (long pass = 0; pass < passes; ++pass) {
    for (long i = 0; i < n; ++i) a[i] += s;
    // Every pass goes through memory: without this the compiler may swap the
    // loops and keep each element in a register for all the passes.
    asm volatile("" : : "r"(a) : "memory");
  }
}

double CoreLoadStoreGbPerS(int core, std::chrono::milliseconds duration) {
  constexpr long kElements = 4096;  // 16 KiB of floats
  constexpr long kPassesPerCheck = 64;
  double gb_s = std::numeric_limits<double>::quiet_NaN();
  std::thread probe([&] {
    cpu_set_t cores;
    CPU_ZERO(&cores);
    CPU_SET(core, &cores);
    if (pthread_setaffinity_np(pthread_self(), sizeof cores, &cores) != 0) return;
    std::vector<float> a(kElements, 0.0f);
    AddInPlace(a.data(), kElements, 1.0f, kPassesPerCheck);  // into the cache
    long passes = 0;
    const Clock::time_point start = Clock::now();
    Clock::time_point now;
    do {
      AddInPlace(a.data(), kElements, 1.0f, kPassesPerCheck);
      passes += kPassesPerCheck;
      now = Clock::now();
    } while (now - start < duration);
    gb_s = 8.0 * kElements * passes / std::chrono::duration<double>(now - start).count() * 1e-9;
  });
  probe.join();
  return gb_s;
}

std::vector<double> EachCoreLoadStoreGbPerS(std::chrono::milliseconds duration) {
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<double> gb_s;
  for (int core = 0; core < cores; ++core) gb_s.push_back(CoreLoadStoreGbPerS(core, duration));
  return gb_s;
}

std::string CoreLoadStoreText(const std::vector<double>& gb_s) {
  if (gb_s.empty()) return "-";
  std::string text;
  for (size_t core = 0; core < gb_s.size(); ++core) {
    if (core > 0) text += '/';
    text += std::isnan(gb_s[core]) ? std::string("-") : std::to_string(std::lround(gb_s[core]));
  }
  return text;
}

MachinePeaks MeasureMachinePeaks(int max_threads) {
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  MachinePeaks peaks;
  TriadArrays arrays;
  for (int threads = 1; threads <= std::min(max_threads, cores); ++threads) {
    peaks.fma_fp32_gflops.push_back(FmaGflops(threads));
    peaks.triad_gb_s.push_back(TriadGbPerS(threads, arrays));
  }
  peaks.core_load_store_gb_s = EachCoreLoadStoreGbPerS(std::chrono::milliseconds(100));
  return peaks;
}

}  // namespace dg::tools
