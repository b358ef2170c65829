#include "pipeline/run_statistics.h"

#include <algorithm>
#include <cstdio>
#include <map>

#include "sim/statistics.h"

namespace dg::pipeline {

RunStatistics Summarize(std::span<const StageTiming> timings, const std::vector<std::string>& stage_names,
                        std::int64_t dropped, double wall_s, double video_fps, bool complete) {
  RunStatistics summary;
  summary.dropped = dropped;
  summary.complete = complete;
  const int sink = static_cast<int>(stage_names.size()) - 1;

  std::vector<std::vector<double>> durations(stage_names.size());
  std::map<std::int64_t, std::pair<std::int64_t, std::int64_t>> span_of_frame;  // capture start, sink end
  std::int64_t first_ns = INT64_MAX, last_ns = 0;
  for (const StageTiming& t : timings) {
    if (t.stage < 0 || t.stage > sink) continue;
    durations[t.stage].push_back((t.end_ns - t.start_ns) * 1e-6);
    first_ns = std::min(first_ns, t.start_ns);
    last_ns = std::max(last_ns, t.end_ns);
    if (t.stage == 0) span_of_frame[t.frame].first = t.start_ns;
    if (t.stage == sink) span_of_frame[t.frame].second = t.end_ns;
  }
  for (size_t s = 0; s < stage_names.size(); ++s) {
    std::vector<double>& d = durations[s];
    StageStatistics stage{stage_names[s], static_cast<std::int64_t>(d.size())};
    if (!d.empty()) {
      double sum = 0;
      for (double v : d) sum += v;
      stage.mean_ms = sum / d.size();
      stage.median_ms = sim::Median(d);
      stage.p95_ms = sim::Quantile(d, 0.95);
    }
    summary.stages.push_back(stage);
  }

  std::vector<double> latency;
  for (const auto& [frame, span] : span_of_frame) {
    if (span.second > 0) latency.push_back((span.second - span.first) * 1e-6);
  }
  summary.frames = static_cast<std::int64_t>(latency.size());
  summary.latency_median_ms = sim::Median(latency);
  summary.latency_p95_ms = sim::Quantile(latency, 0.95);
  summary.wall_s = wall_s > 0 ? wall_s : (last_ns > first_ns ? (last_ns - first_ns) * 1e-9 : 0);
  if (summary.wall_s > 0) {
    summary.frames_per_s = summary.frames / summary.wall_s;
    if (video_fps > 0) summary.realtime_factor = (summary.frames + dropped) / video_fps / summary.wall_s;
  }
  return summary;
}

std::string RunStatistics::Text() const {
  std::string text;
  char line[256];
  std::snprintf(line, sizeof line, "%-24s %8s %10s %10s %10s\n", "stage", "frames", "median ms", "p95 ms", "mean ms");
  text += line;
  for (const StageStatistics& s : stages) {
    std::snprintf(line, sizeof line, "%-24s %8lld %10.2f %10.2f %10.2f\n", s.name.c_str(),
                  static_cast<long long>(s.frames), s.median_ms, s.p95_ms, s.mean_ms);
    text += line;
  }
  std::snprintf(line, sizeof line,
                "frames %lld, dropped %lld, %.2f s wall, %.1f frames/s, real-time factor %.2f\n"
                "latency capture to sink: median %.1f ms, p95 %.1f ms%s\n",
                static_cast<long long>(frames), static_cast<long long>(dropped), wall_s, frames_per_s,
                realtime_factor, latency_median_ms, latency_p95_ms, complete ? "" : "\nthe run is INCOMPLETE");
  text += line;
  return text;
}

}  // namespace dg::pipeline
