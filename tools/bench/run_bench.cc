#include "tools/bench/run_bench.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "pipeline/run_scene.h"
#include "sim/statistics.h"
#include "tools/bench/bench_json.h"
#include "tools/bench/machine_peaks.h"
#include "tools/bench/pipeline_bench.h"
#include "tools/json_text.h"
#include "tools/phantom/phantom_cache.h"

namespace dg::tools {
namespace {

struct Spread {
  double median = 0, low = 0, high = 0;
};

Spread SpreadOf(const std::vector<double>& values) {
  const auto [low, high] = std::minmax_element(values.begin(), values.end());
  return {sim::Median(values), *low, *high};
}

// The machine a run is about to meet (RunBenchRecord::host, core_load_store_gb_s).
void SampleMachine(int threads, RunBenchRecord* record) {
  constexpr std::chrono::milliseconds kSample{20};
  record->host = MeasureHostInterruptions(threads, kSample);
  record->core_load_store_gb_s = EachCoreLoadStoreGbPerS(kSample);
}

}  // namespace

std::vector<RunBenchRecord> RunRunBench(const RunBenchOptions& options, bool progress) {
  // Each run writes its log as a user's would (the sink's work is part of the
  // run), into a scratch folder removed afterwards.
  const std::filesystem::path scratch =
      std::filesystem::temp_directory_path() / ("dg_bench_run_" + std::to_string(getpid()));
  std::vector<RunBenchRecord> records;
  for (pipeline::Policy policy : options.policies) {
    for (int repeat = 0; repeat < options.repeats; ++repeat) {
      if (progress) {
        std::fprintf(stderr, "bench run: %s, %d threads, run %d of %d\n", pipeline::PolicyName(policy),
                     options.threads, repeat + 1, options.repeats);
      }
      pipeline::RunOptions run;
      run.scene = options.scene.empty() ? DefaultScenePath(progress) : options.scene;
      run.out_dir = scratch.string();
      run.threads = options.threads;
      run.graph.policy = policy;
      run.video = false;
      run.progress = false;
      RunBenchRecord record;
      record.policy = policy;
      record.threads = options.threads;
      record.repeat = repeat;
      SampleMachine(options.threads, &record);
      const pipeline::RunOutcome outcome = pipeline::RunScene(run);
      record.statistics = outcome.statistics;
      record.simulated_frames = outcome.simulated_frames;
      record.overlays = outcome.overlays;
      records.push_back(std::move(record));
    }
  }
  std::filesystem::remove_all(scratch);
  return records;
}

std::string RunBenchTable(const std::vector<RunBenchRecord>& records) {
  std::string table =
      "| policy | threads | run | frames | dropped | real-time factor | latency median / p95 ms | "
      "before: host took % (any core) | before: cores' L1 load/store GB/s |\n"
      "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const RunBenchRecord& r : records) {
    const pipeline::RunStatistics& s = r.statistics;
    table += Printed("| %s | %d | %d | %lld | %lld | %.2f | %.1f / %.1f | %.1f (%.1f) | %s |\n",
                     pipeline::PolicyName(r.policy), r.threads, r.repeat + 1, static_cast<long long>(s.frames),
                     static_cast<long long>(s.dropped), s.realtime_factor, s.latency_median_ms, s.latency_p95_ms,
                     r.host.per_core_percent, r.host.any_core_percent, CoreLoadStoreText(r.core_load_store_gb_s).c_str());
  }
  for (pipeline::Policy policy : {pipeline::Policy::kOffline, pipeline::Policy::kRealtime}) {
    std::vector<double> factor, median, p95;
    long long dropped = 0;
    for (const RunBenchRecord& r : records) {
      if (r.policy != policy) continue;
      factor.push_back(r.statistics.realtime_factor);
      median.push_back(r.statistics.latency_median_ms);
      p95.push_back(r.statistics.latency_p95_ms);
      dropped += r.statistics.dropped;
    }
    if (factor.empty()) continue;
    const Spread f = SpreadOf(factor), m = SpreadOf(median), p = SpreadOf(p95);
    table += Printed("%s: real-time factor %.2f (%.2f-%.2f), latency median %.1f ms (%.1f-%.1f), p95 %.1f ms "
                     "(%.1f-%.1f), %lld frames dropped in %zu runs\n",
                     pipeline::PolicyName(policy), f.median, f.low, f.high, m.median, m.low, m.high, p.median, p.low,
                     p.high, dropped, factor.size());
  }
  return table;
}

void WriteRunBenchJson(const std::string& path, const std::vector<RunBenchRecord>& records) {
  std::vector<std::string> texts;
  for (const RunBenchRecord& r : records) {
    const pipeline::RunStatistics& s = r.statistics;
    nlohmann::ordered_json record = {{"policy", pipeline::PolicyName(r.policy)},
                                     {"threads", r.threads},
                                     {"repeat", r.repeat + 1},
                                     {"frames", s.frames},
                                     {"dropped", s.dropped},
                                     {"realtime_factor", Significant(s.realtime_factor, 4)},
                                     {"latency_ms_median", Significant(s.latency_median_ms, 4)},
                                     {"latency_ms_p95", Significant(s.latency_p95_ms, 4)},
                                     {"simulated_frames", r.simulated_frames},
                                     {"host_took_percent", Significant(r.host.per_core_percent, 3)},
                                     {"host_took_any_core_percent", Significant(r.host.any_core_percent, 3)},
                                     {"core_load_store_gb_s", SignificantEach(r.core_load_store_gb_s, 3)},
                                     {"stages", nlohmann::ordered_json::parse(StageTimingsJson(s))}};
    if (r.overlays) {
      nlohmann::ordered_json draws;
      for (size_t k = 0; k < r.overlays->names.size(); ++k) {
        draws[r.overlays->names[k]] = Significant(r.overlays->draw_ms_median[k], 4);
      }
      record["overlays"] = {{"composed_frames", r.overlays->composed_frames},
                            {"frames_with_layers", r.overlays->frames_with_layers},
                            {"layer_age_median_frames", r.overlays->age_median_frames},
                            {"layer_age_max_frames", r.overlays->age_max_frames},
                            {"draw_ms_median", draws}};
    }
    texts.push_back(JsonText(record, -1));
  }
  WriteBenchJson(path, texts);
}

}  // namespace dg::tools
