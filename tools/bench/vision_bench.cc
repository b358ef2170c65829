#include "tools/bench/vision_bench.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <span>

#include <unistd.h>

#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <tbb/global_control.h>

#include "pipeline/scene_graph.h"
#include "sim/error.h"
#include "sim/statistics.h"
#include "tools/bench/bench_json.h"
#include "tools/json_text.h"
#include "tools/phantom/phantom_generator.h"
#include "tools/phantom/phantom_spec.h"
#include "tools/track/front_end.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;

// One frame through the front-end graph: its stages' times and the tracker's parts.
struct FrameTimes {
  double capture_ms = 0, rectify_ms = 0, track_ms = 0;
  std::int64_t tracked_ns = 0;  // when the tracker finished it
  stages::TrackTimings track;
  double features = 0;
};

// Collects every frame's times; the stage timings of a frame arrive after its packet.
class TimingSink final : public pipeline::GraphSink {
 public:
  explicit TimingSink(const std::vector<std::string>& stage_names) : stage_names_(stage_names) {}

  void Consume(const pipeline::FramePacket& packet) override {
    FrameTimes& frame = frames_.emplace_back();
    frame.track = packet.track_timings;
    frame.features = double(packet.tracks.points.size());
  }
  void RecordTimings(std::span<const pipeline::StageTiming> timings) override {
    FrameTimes& frame = frames_.back();
    for (const pipeline::StageTiming& t : timings) {
      const std::string& stage = stage_names_[t.stage];
      const double ms = 1e-6 * double(t.end_ns - t.start_ns);
      if (stage == "capture") frame.capture_ms = ms;
      if (stage == "rectify") frame.rectify_ms = ms;
      if (stage == "track") {
        frame.track_ms = ms;
        frame.tracked_ns = t.end_ns;
      }
    }
  }
  void RecordDrop(std::int64_t, std::int64_t) override {}  // offline: the graph drops nothing

  const std::vector<FrameTimes>& frames() const { return frames_; }

 private:
  const std::vector<std::string>& stage_names_;
  std::vector<FrameTimes> frames_;
};

// The median over frames of one part's time.
double MedianOf(const std::vector<FrameTimes>& frames, const std::function<double(const FrameTimes&)>& part) {
  std::vector<double> values;
  for (const FrameTimes& f : frames) values.push_back(part(f));
  return sim::Median(values);
}

VisionBenchRecord Measure(const std::string& scene, int threads, const VisionBenchOptions& options) {
  // OpenCV's kernels (LK, remap) run on OpenCV's own thread pool, which TBB's limit may not reach.
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
  const int opencv_threads = cv::getNumThreads();
  cv::setNumThreads(threads);
  FrontEndInput input;
  input.scene = scene;
  pipeline::GraphOptions graph;
  if (options.frames > 0) graph.end_frame = options.frames;
  const pipeline::SceneGraph built = pipeline::BuildSceneGraph(FrontEndScene(input), graph, FrontEndSettingsOf(input));
  TimingSink sink(built.graph->stage_names());
  const pipeline::GraphRunResult result = built.graph->Run(sink);
  cv::setNumThreads(opencv_threads);
  if (!result.complete) throw Error(result.error, scene, "check the phantom the benchmark generated");
  const std::vector<FrameTimes>& frames = sink.frames();
  std::vector<double> work_ms, interval_ms;
  for (size_t k = 0; k < frames.size(); ++k) {
    work_ms.push_back(frames[k].capture_ms + frames[k].rectify_ms + frames[k].track_ms);
    if (k > 0) interval_ms.push_back(1e-6 * double(frames[k].tracked_ns - frames[k - 1].tracked_ns));
  }

  VisionBenchRecord r;
  r.threads = threads;
  r.width = built.calibration.left.width;
  r.height = built.calibration.left.height;
  r.frames = static_cast<int>(frames.size());
  r.features = static_cast<int>(MedianOf(frames, [](const FrameTimes& f) { return f.features; }));
  r.ms_median = sim::Median(work_ms);
  r.ms_p95 = sim::Quantile(work_ms, 0.95);
  r.fps = result.wall_s > 0 ? double(r.frames) / result.wall_s : 0;
  r.interval_ms_median = interval_ms.empty() ? 0 : sim::Median(interval_ms);
  r.capture_ms = MedianOf(frames, [](const FrameTimes& f) { return f.capture_ms; });
  r.rectify_ms = MedianOf(frames, [](const FrameTimes& f) { return f.rectify_ms; });
  r.temporal_ms = MedianOf(frames, [](const FrameTimes& f) { return f.track.temporal_ms; });
  r.detect_ms = MedianOf(frames, [](const FrameTimes& f) { return f.track.detect_ms; });
  r.stereo_ms = MedianOf(frames, [](const FrameTimes& f) { return f.track.stereo_ms; });
  r.triangulate_ms = MedianOf(frames, [](const FrameTimes& f) { return f.track.triangulate_ms; });
  for (const FrameTimes& f : frames) r.detect_ms_max = std::max(r.detect_ms_max, f.track.detect_ms);
  return r;
}

// The repeats of one configuration: the run of median fps, and the spread.
VisionBenchRecord Repeated(const std::string& scene, int threads, const VisionBenchOptions& options) {
  std::vector<VisionBenchRecord> runs;
  for (int k = 0; k < options.repeats; ++k) runs.push_back(Measure(scene, threads, options));
  std::sort(runs.begin(), runs.end(), [](const auto& a, const auto& b) { return a.fps < b.fps; });
  VisionBenchRecord record = runs[runs.size() / 2];
  record.repeats = options.repeats;
  record.fps_min = runs.front().fps;
  record.fps_max = runs.back().fps;
  return record;
}

}  // namespace

std::vector<VisionBenchRecord> RunVisionBench(const VisionBenchOptions& options, bool progress) {
  if (!(options.duration_s > 0)) throw Error("the phantom's duration must be positive", "dynaguide bench vision", "give e.g. 2");
  if (options.repeats < 1) throw Error("repeats must be at least 1", "dynaguide bench vision --repeats", "give e.g. 3");
  std::vector<VisionBenchRecord> records;
  for (const std::string& codec : options.codecs) {
    phantom::PhantomSpec spec = phantom::PresetSpec("default");
    spec.duration_s = options.duration_s;
    spec.video_codec = codec;
    if (const std::string problem = spec.Validate(); !problem.empty()) {
      throw Error(problem, "dynaguide bench vision --codecs", "give raw, huffyuv or both");
    }
    // One folder per process and codec: two benchmarks may run at once.
    const fs::path dir = fs::temp_directory_path() / ("dg_bench_vision_" + std::to_string(::getpid()) + "_" + codec);
    fs::remove_all(dir);
    if (progress) {
      std::fprintf(stderr, "bench vision: generating a %.1f s default phantom (%s video) in %s\n", spec.duration_s,
                   codec.c_str(), dir.c_str());
    }
    phantom::GeneratePhantom(spec, dir.string(), false);
    for (int threads : options.threads) {
      records.push_back(Repeated((dir / "scene.yaml").string(), threads, options));
      VisionBenchRecord& r = records.back();
      r.codec = codec;
      if (progress) {
        std::fprintf(stderr,
                     "bench vision: %s video, %d thread%s: %.1f ms median, %.1f ms p95 over %d frames, %d features, "
                     "%.0f frames/s (%.0f-%.0f over %d runs)\n",
                     codec.c_str(), r.threads, r.threads > 1 ? "s" : "", r.ms_median, r.ms_p95, r.frames, r.features, r.fps,
                     r.fps_min, r.fps_max, r.repeats);
      }
    }
    fs::remove_all(dir);
  }
  return records;
}

void WriteVisionBenchJson(const std::string& path, const std::vector<VisionBenchRecord>& records) {
  std::vector<std::string> texts;
  for (const VisionBenchRecord& r : records) {
    const nlohmann::ordered_json record = {{"codec", r.codec},
                                           {"threads", r.threads},
                                           {"width", r.width},
                                           {"height", r.height},
                                           {"frames", r.frames},
                                           {"features", r.features},
                                           {"ms_median", Significant(r.ms_median, 4)},
                                           {"ms_p95", Significant(r.ms_p95, 4)},
                                           {"fps", Significant(r.fps, 4)},
                                           {"repeats", r.repeats},
                                           {"fps_min", Significant(r.fps_min, 4)},
                                           {"fps_max", Significant(r.fps_max, 4)},
                                           {"interval_ms_median", Significant(r.interval_ms_median, 4)},
                                           {"capture_ms", Significant(r.capture_ms, 4)},
                                           {"rectify_ms", Significant(r.rectify_ms, 4)},
                                           {"temporal_ms", Significant(r.temporal_ms, 4)},
                                           {"detect_ms", Significant(r.detect_ms, 4)},
                                           {"detect_ms_max", Significant(r.detect_ms_max, 4)},
                                           {"stereo_ms", Significant(r.stereo_ms, 4)},
                                           {"triangulate_ms", Significant(r.triangulate_ms, 4)}};
    texts.push_back(JsonText(record, -1));
  }
  WriteBenchJson(path, texts);
}

std::string VisionBenchTable(const std::vector<VisionBenchRecord>& records) {
  std::string table =
      "| codec | threads | size | features | ms median | ms p95 | fps (min-max) | steady fps | capture | rectify | temporal (LK) | detect (median/max) "
      "| stereo | triangulate |\n"
      "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const VisionBenchRecord& r : records) {
    char line[320];
    std::snprintf(line, sizeof line,
                  "| %s | %d | %dx%d | %d | %.1f | %.1f | %.0f (%.0f-%.0f) | %.0f | %.2f | %.2f | %.2f | %.2f / %.1f | %.2f | %.2f |\n",
                  r.codec.c_str(), r.threads, r.width, r.height, r.features, r.ms_median, r.ms_p95, r.fps, r.fps_min, r.fps_max,
                  r.interval_ms_median > 0 ? 1e3 / r.interval_ms_median : 0, r.capture_ms, r.rectify_ms,
                  r.temporal_ms, r.detect_ms, r.detect_ms_max, r.stereo_ms, r.triangulate_ms);
    table += line;
  }
  return table;
}

}  // namespace dg::tools
