#pragma once

#include <string>
#include <vector>

#include "pipeline/run_statistics.h"

namespace dg::tools {

struct PipelineBenchOptions {
  std::string scene;  // empty: the built-in default scene (the default phantom)
  std::vector<int> threads{1, 2};
  int repeats = 3;    // per configuration; the run of median wall time is reported
  int frames = 0;     // 0: the whole recording
};

// One configuration: the front-end graph of the scene, offline, through the
// TBB flow graph ("graph") or with the same stages called one after another
// on one thread ("sequential").
struct PipelineBenchRecord {
  std::string mode;
  int threads = 0;
  pipeline::RunStatistics statistics;
  // graph only: its wall time over the sequential run's at the same thread
  // count, minus one, in percent (negative: the graph is faster, by overlapping stages)
  double overhead_pct = 0;
  double speedup = 1;  // graph only: the 1-thread graph's wall time over this one's
  // The runs measured (statistics is the one of median wall time) and the
  // spread of their frames/s.
  int repeats = 1;
  double fps_min = 0, fps_max = 0;
};

// @throws dg::Error for an unreadable scene.
std::vector<PipelineBenchRecord> RunPipelineBench(const PipelineBenchOptions& options, bool progress);
// Each stage's timings as one JSON object's text: {"name": {"median_ms": .., "p95_ms": ..}, ...}
std::string StageTimingsJson(const pipeline::RunStatistics& statistics);
std::string PipelineBenchTable(const std::vector<PipelineBenchRecord>& records);
// Records with threads, mode, frames, fps (with fps_min, fps_max over the
// repeats), realtime_factor, latency_ms_median, latency_ms_p95, overhead_pct,
// speedup, each stage's median and p95 ms, the machine and the provenance.
void WritePipelineBenchJson(const std::string& path, const std::vector<PipelineBenchRecord>& records);

}  // namespace dg::tools
