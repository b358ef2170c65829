#pragma once

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

}  // namespace dg::tools
