#pragma once

#include <chrono>
#include <string>
#include <vector>

namespace dg::tools {

// How fast the host was when a benchmark ran, measured in the benchmark's own
// process (docs/benchmarks.md, "The host's peaks"): a shared virtual machine's
// cores change speed from minute to minute, and a figure is only comparable
// with another beside the machine's own peaks of the same minute.
struct MachinePeaks {
  // Single-precision FMA throughput on 1, 2, ... threads at once (the widest
  // FMA the CPU has: AVX-512, AVX2 or scalar), GFLOP/s.
  std::vector<double> fma_fp32_gflops;
  // A streaming triad a = b + s c over arrays far larger than the caches, on
  // 1, 2, ... threads, GB/s, counting 24 bytes an element (the write's
  // allocation read is not counted, as STREAM does not).
  std::vector<double> triad_gb_s;
  // Each logical core alone, the probe's thread pinned to it: loads and
  // stores that stay in the core's L1 cache (CoreLoadStoreGbPerS). A shared
  // host can slow one virtual core's loads and stores while its FMAs keep
  // their speed; a solver, whose step is mostly loads and stores, feels it
  // and the FMA peak does not show it (docs/benchmarks.md, "The host's peaks").
  std::vector<double> core_load_store_gb_s;
};

// On 1 to `max_threads` threads (at most the logical cores); about a second.
MachinePeaks MeasureMachinePeaks(int max_threads = 2);

// The FMA kernel on vectors of `lanes` floats (16: AVX-512, 8: AVX2, 1:
// scalar): kFmaChains vectors, every lane of chain c starting at c, each
// advanced `iterations` times by x = x * a + b with one rounding (fused).
// Writes the final values to `out` (lanes * kFmaChains of them). Exposed for
// its test. @pre lanes is 1, or 8 or 16 and at most FmaLanes()
constexpr int kFmaChains = 12;  // independent chains: enough to fill two FMA pipes of 4 cycles' latency
int FmaLanes();                 // lanes of the widest FMA this CPU runs: 16, 8 or 1
void RunFmaChains(int lanes, float a, float b, long iterations, float* out);

// The triad kernel on [begin, end): a[i] = b[i] + s * c[i]. Exposed for its test.
void Triad(double* a, const double* b, const double* c, double s, long begin, long end);

// The load/store kernel: `passes` times, a[i] += s for every i in [0, n),
// each pass reading and writing the whole array. Exposed for its test.
void AddInPlace(float* a, long n, float s, long passes);

// AddInPlace over 16 KiB (inside any x86-64 core's L1 data cache, 32-48
// KiB) on a thread pinned to logical core `core`, for about `duration`:
// GB/s counting a 4-byte load and a 4-byte store an element. NaN when no thread can be pinned to that core (one outside the
// process's cpuset, as in a container given fewer cores).
double CoreLoadStoreGbPerS(int core, std::chrono::milliseconds duration);

// CoreLoadStoreGbPerS of every logical core in turn, each alone.
std::vector<double> EachCoreLoadStoreGbPerS(std::chrono::milliseconds duration);

// Each core's figure in GB/s, for a table: "327/253"; "-" for none.
std::string CoreLoadStoreText(const std::vector<double>& gb_s);

}  // namespace dg::tools
