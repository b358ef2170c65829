#include "tools/bench/pipeline_bench.h"

#include <algorithm>
#include <cstdio>

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "io/scene.h"
#include "pipeline/scene_graph.h"
#include "sim/error.h"
#include "tools/bench/bench_json.h"
#include "tools/json_text.h"
#include "tools/phantom/phantom_cache.h"

namespace dg::tools {
namespace {

// Keeps the timings in memory: the benchmark measures the graph, not the disk.
class TimingSink final : public pipeline::GraphSink {
 public:
  void Consume(const pipeline::FramePacket&) override {}
  void RecordTimings(std::span<const pipeline::StageTiming> timings) override {
    rows.insert(rows.end(), timings.begin(), timings.end());
  }
  void RecordDrop(std::int64_t, std::int64_t) override {}
  std::vector<pipeline::StageTiming> rows;
};

pipeline::RunStatistics RunOnce(const io::Scene& scene, const PipelineBenchOptions& options, bool graph) {
  pipeline::GraphOptions graph_options;
  if (options.frames > 0) graph_options.end_frame = options.frames;
  const pipeline::SceneGraph built = pipeline::BuildSceneGraph(scene, graph_options);
  TimingSink sink;
  const pipeline::GraphRunResult result = graph ? built.graph->Run(sink) : built.graph->RunInline(sink);
  if (!result.complete) throw Error(result.error, scene.path, "run `dynaguide run` on the scene to see the failure");
  return pipeline::Summarize(sink.rows, built.graph->stage_names(), 0, result.wall_s, built.graph->source().fps(),
                             true);
}

// The repeats of one configuration: the run of median wall time, and the spread.
PipelineBenchRecord Repeated(const io::Scene& scene, const PipelineBenchOptions& options, bool graph, int threads) {
  std::vector<pipeline::RunStatistics> runs;
  for (int r = 0; r < options.repeats; ++r) runs.push_back(RunOnce(scene, options, graph));
  std::sort(runs.begin(), runs.end(), [](const auto& a, const auto& b) { return a.wall_s < b.wall_s; });
  PipelineBenchRecord record{graph ? "graph" : "sequential", threads, runs[runs.size() / 2]};
  record.repeats = options.repeats;
  record.fps_max = runs.front().frames_per_s;
  record.fps_min = runs.back().frames_per_s;
  return record;
}

}  // namespace

std::vector<PipelineBenchRecord> RunPipelineBench(const PipelineBenchOptions& options, bool progress) {
  io::Scene scene = io::ReadScene(options.scene.empty() ? DefaultScenePath(progress) : options.scene);
  // The front end's graph (capture, rectify, track): registration, simulation
  // and overlays have benchmarks of their own.
  scene.registration.reset();
  scene.simulation.reset();
  std::vector<PipelineBenchRecord> records;
  double graph_1_thread_s = 0;
  for (int threads : options.threads) {
    tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
    if (progress) std::fprintf(stderr, "bench pipeline: %d thread(s), %d repeats each\n", threads, options.repeats);
    PipelineBenchRecord sequential = Repeated(scene, options, false, threads);
    PipelineBenchRecord graph = Repeated(scene, options, true, threads);
    graph.overhead_pct = 100 * (graph.statistics.wall_s / sequential.statistics.wall_s - 1);
    if (threads == 1) graph_1_thread_s = graph.statistics.wall_s;
    if (graph_1_thread_s > 0) graph.speedup = graph_1_thread_s / graph.statistics.wall_s;
    records.push_back(sequential);
    records.push_back(graph);
  }
  return records;
}

std::string StageTimingsJson(const pipeline::RunStatistics& statistics) {
  nlohmann::ordered_json stages = nlohmann::ordered_json::object();
  for (const pipeline::StageStatistics& stage : statistics.stages) {
    stages[stage.name] = {{"median_ms", Significant(stage.median_ms, 4)}, {"p95_ms", Significant(stage.p95_ms, 4)}};
  }
  return JsonText(stages, -1);
}

std::string PipelineBenchTable(const std::vector<PipelineBenchRecord>& records) {
  std::string table =
      "| threads | mode | frames | frames/s | real-time factor | latency median / p95 ms | overhead | speed-up |\n"
      "|---:|---|---:|---:|---:|---:|---:|---:|\n";
  for (const PipelineBenchRecord& r : records) {
    char overhead[32] = "", speedup[32] = "";
    if (r.mode == "graph") {
      std::snprintf(overhead, sizeof overhead, "%+.1f%%", r.overhead_pct);
      std::snprintf(speedup, sizeof speedup, "%.2fx", r.speedup);
    }
    char line[256];
    std::snprintf(line, sizeof line, "| %d | %s | %lld | %.1f | %.2f | %.1f / %.1f | %s | %s |\n", r.threads,
                  r.mode.c_str(), static_cast<long long>(r.statistics.frames), r.statistics.frames_per_s,
                  r.statistics.realtime_factor, r.statistics.latency_median_ms, r.statistics.latency_p95_ms, overhead,
                  speedup);
    table += line;
  }
  return table;
}

void WritePipelineBenchJson(const std::string& path, const std::vector<PipelineBenchRecord>& records) {
  std::vector<std::string> texts;
  for (const PipelineBenchRecord& r : records) {
    const pipeline::RunStatistics& s = r.statistics;
    const nlohmann::ordered_json record = {{"threads", r.threads},
                                           {"mode", r.mode},
                                           {"frames", s.frames},
                                           {"fps", Significant(s.frames_per_s, 4)},
                                           {"repeats", r.repeats},
                                           {"fps_min", Significant(r.fps_min, 4)},
                                           {"fps_max", Significant(r.fps_max, 4)},
                                           {"realtime_factor", Significant(s.realtime_factor, 4)},
                                           {"latency_ms_median", Significant(s.latency_median_ms, 4)},
                                           {"latency_ms_p95", Significant(s.latency_p95_ms, 4)},
                                           {"overhead_pct", Significant(r.overhead_pct, 3)},
                                           {"speedup", Significant(r.speedup, 3)},
                                           {"stages", nlohmann::ordered_json::parse(StageTimingsJson(s))}};
    texts.push_back(JsonText(record, -1));
  }
  WriteBenchJson(path, texts);
}

}  // namespace dg::tools
