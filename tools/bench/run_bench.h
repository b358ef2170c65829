#pragma once

#include <optional>
#include <string>
#include <vector>

#include "pipeline/overlay_log.h"
#include "pipeline/run_statistics.h"
#include "pipeline/stage_graph.h"
#include "tools/bench/host_interruptions.h"

namespace dg::tools {

struct RunBenchOptions {
  std::string scene;  // empty: the built-in default scene (the default phantom)
  std::vector<pipeline::Policy> policies{pipeline::Policy::kOffline, pipeline::Policy::kRealtime};
  int threads = 2;
  int repeats = 3;  // runs per policy, each reported: the spread is the figure's
};

// One `dynaguide run` of the whole scene (every stage its scene needs, the
// overlays included; no annotated video), as a user streams a recording.
struct RunBenchRecord {
  pipeline::Policy policy = pipeline::Policy::kOffline;
  int threads = 0;
  int repeat = 0;
  pipeline::RunStatistics statistics;  // dropped, real-time factor, latency, each stage's timings
  std::int64_t simulated_frames = 0;
  std::optional<pipeline::OverlaySummary> overlays;  // a scene with overlays: what they showed, their draw times
  // The machine just before the run: what the host took from `threads`
  // cores (tools/bench/host_interruptions.h), and each core alone at L1
  // loads and stores (tools/bench/machine_peaks.h), so that a slow run is
  // read against the state it met.
  HostInterruptions host;
  std::vector<double> core_load_store_gb_s;
};

// @throws dg::Error for an unreadable scene, or a run that fails (naming it).
std::vector<RunBenchRecord> RunRunBench(const RunBenchOptions& options, bool progress);
// Each run, then per policy the median and range of the real-time factor and latency.
std::string RunBenchTable(const std::vector<RunBenchRecord>& records);
// Records with policy, threads, repeat, frames, dropped, realtime_factor,
// latency_ms_median, latency_ms_p95, simulated_frames, host_took_percent,
// host_took_any_core_percent, core_load_store_gb_s (just before the run),
// each stage's median and p95 ms, with overlays the frames composed with
// every layer, the layers' median and largest age and each overlay's median
// draw ms in the run, and the machine.
void WriteRunBenchJson(const std::string& path, const std::vector<RunBenchRecord>& records);

}  // namespace dg::tools
