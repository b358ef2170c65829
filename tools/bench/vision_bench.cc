#include "tools/bench/vision_bench.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <functional>

#include <unistd.h>

#include <opencv2/core/utility.hpp>
#include <tbb/global_control.h>

#include "sim/error.h"
#include "tools/bench/bench_json.h"
#include "tools/json_text.h"
#include "tools/phantom/phantom_generator.h"
#include "tools/phantom/phantom_spec.h"
#include "tools/track/front_end.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * values.size()));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

// The median over frames of one part's time.
double MedianOf(const std::vector<FrontEndTimings>& timings, const std::function<double(const FrontEndTimings&)>& part) {
  std::vector<double> values;
  for (const FrontEndTimings& t : timings) values.push_back(part(t));
  return Percentile(values, 0.5);
}

VisionBenchRecord Measure(const std::string& scene, int threads, const VisionBenchOptions& options) {
  // OpenCV's kernels (LK, remap) run on OpenCV's own thread pool, which TBB's limit may not reach.
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
  const int opencv_threads = cv::getNumThreads();
  cv::setNumThreads(threads);
  FrontEndInput input;
  input.scene = scene;
  FrontEnd front_end(input);
  std::vector<FrontEndTimings> timings;
  std::vector<double> total_ms, features;
  FrontEndTimings t;
  while (options.frames <= 0 || static_cast<int>(timings.size()) < options.frames) {
    const std::optional<FrontEndFrame> frame = front_end.Next(&t);
    if (!frame) break;
    timings.push_back(t);
    total_ms.push_back(t.total_ms());
    features.push_back(double(frame->tracks.points.size()));
  }
  VisionBenchRecord r;
  r.threads = threads;
  r.width = front_end.size().width;
  r.height = front_end.size().height;
  r.frames = static_cast<int>(timings.size());
  r.features = static_cast<int>(Percentile(features, 0.5));
  r.ms_median = Percentile(total_ms, 0.5);
  r.ms_p95 = Percentile(total_ms, 0.95);
  r.fps = r.ms_median > 0 ? 1e3 / r.ms_median : 0;
  r.capture_ms = MedianOf(timings, [](const FrontEndTimings& x) { return x.capture_ms; });
  r.rectify_ms = MedianOf(timings, [](const FrontEndTimings& x) { return x.rectify_ms; });
  r.temporal_ms = MedianOf(timings, [](const FrontEndTimings& x) { return x.track.temporal_ms; });
  r.detect_ms = MedianOf(timings, [](const FrontEndTimings& x) { return x.track.detect_ms; });
  r.stereo_ms = MedianOf(timings, [](const FrontEndTimings& x) { return x.track.stereo_ms; });
  r.triangulate_ms = MedianOf(timings, [](const FrontEndTimings& x) { return x.track.triangulate_ms; });
  for (const FrontEndTimings& x : timings) r.detect_ms_max = std::max(r.detect_ms_max, x.track.detect_ms);
  cv::setNumThreads(opencv_threads);
  return r;
}

}  // namespace

std::vector<VisionBenchRecord> RunVisionBench(const VisionBenchOptions& options, bool progress) {
  if (!(options.duration_s > 0)) throw Error("the phantom's duration must be positive", "dynaguide bench vision", "give e.g. 2");
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
      records.push_back(Measure((dir / "scene.yaml").string(), threads, options));
      VisionBenchRecord& r = records.back();
      r.codec = codec;
      if (progress) {
        std::fprintf(stderr, "bench vision: %s video, %d thread%s: %.1f ms median, %.1f ms p95 over %d frames, %d features\n",
                     codec.c_str(), r.threads, r.threads > 1 ? "s" : "", r.ms_median, r.ms_p95, r.frames, r.features);
      }
    }
    fs::remove_all(dir);
  }
  return records;
}

void WriteVisionBenchJson(const std::string& path, const std::vector<VisionBenchRecord>& records) {
  std::vector<std::string> fields;
  for (const VisionBenchRecord& r : records) {
    fields.push_back(Printed("\"codec\": \"%s\", \"threads\": %d, \"width\": %d, \"height\": %d, \"frames\": %d, \"features\": %d, "
                             "\"ms_median\": %.4g, \"ms_p95\": %.4g, \"fps\": %.4g, \"capture_ms\": %.4g, "
                             "\"rectify_ms\": %.4g, \"temporal_ms\": %.4g, \"detect_ms\": %.4g, \"detect_ms_max\": %.4g, "
                             "\"stereo_ms\": %.4g, \"triangulate_ms\": %.4g",
                             r.codec.c_str(), r.threads, r.width, r.height, r.frames, r.features, r.ms_median, r.ms_p95, r.fps, r.capture_ms,
                             r.rectify_ms, r.temporal_ms, r.detect_ms, r.detect_ms_max, r.stereo_ms, r.triangulate_ms));
  }
  WriteBenchJson(path, fields);
}

std::string VisionBenchTable(const std::vector<VisionBenchRecord>& records) {
  std::string table =
      "| codec | threads | size | features | ms median | ms p95 | fps | capture | rectify | temporal (LK) | detect (median/max) "
      "| stereo | triangulate |\n"
      "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const VisionBenchRecord& r : records) {
    char line[320];
    std::snprintf(line, sizeof line,
                  "| %s | %d | %dx%d | %d | %.1f | %.1f | %.0f | %.2f | %.2f | %.2f | %.2f / %.1f | %.2f | %.2f |\n",
                  r.codec.c_str(), r.threads, r.width, r.height, r.features, r.ms_median, r.ms_p95, r.fps, r.capture_ms, r.rectify_ms,
                  r.temporal_ms, r.detect_ms, r.detect_ms_max, r.stereo_ms, r.triangulate_ms);
    table += line;
  }
  return table;
}

}  // namespace dg::tools
