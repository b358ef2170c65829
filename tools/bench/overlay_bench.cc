#include "tools/bench/overlay_bench.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>

#include <unistd.h>

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "io/elapsed_time.h"
#include "sim/error.h"
#include "stages/overlay/overlay_error.h"
#include "tools/bench/bench_json.h"
#include "tools/json_text.h"
#include "tools/overlay/phantom_overlay_scene.h"
#include "tools/phantom/phantom_generator.h"
#include "tools/phantom/phantom_spec.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;
namespace overlay = stages::overlay;

// Times work(frame) over options.frames frames (cycling the phantom's) after one untimed call.
OverlayBenchRecord Time(const std::string& name, int threads, int frames, int available,
                        const std::function<void(int)>& work) {
  work(0);
  std::vector<double> ms;
  for (int i = 0; i < frames; ++i) {
    const auto start = std::chrono::steady_clock::now();
    work(i % available);
    ms.push_back(io::MsSince(start));
  }
  OverlayBenchRecord r;
  r.overlay = name;
  r.threads = threads;
  r.frames = frames;
  const overlay::ErrorSummary summary = overlay::Summarize(ms);  // median and p95 of any values
  r.ms_median = summary.median;
  r.ms_p95 = summary.p95;
  r.fps = r.ms_median > 0 ? 1e3 / r.ms_median : 0;
  return r;
}

}  // namespace

std::vector<OverlayBenchRecord> RunOverlayBench(const OverlayBenchOptions& options, bool progress) {
  if (!(options.duration_s > 0) || options.frames < 1)
    throw Error("the phantom's duration and the frame count must be positive", "dynaguide bench overlay",
                "give e.g. --seconds 0.5 --frames 30");
  // One folder per process: two benchmarks may run at once.
  const fs::path dir = fs::temp_directory_path() / ("dg_bench_overlay_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  phantom::PhantomSpec spec = phantom::PresetSpec("default");
  spec.duration_s = options.duration_s;
  if (progress) std::fprintf(stderr, "bench overlay: generating a %.1f s default phantom in %s\n", spec.duration_s, dir.c_str());
  phantom::GeneratePhantom(spec, dir.string(), false);
  const PhantomOverlayScene scene((dir / "scene.yaml").string());
  std::vector<Eigen::Matrix3Xd> nodes;
  std::vector<cv::Mat> video;
  for (int j = 0; j < scene.frames(); ++j) {
    nodes.push_back(scene.TrueNodes(j));
    video.push_back(scene.LeftFrame(j));
  }
  const int available = scene.frames();

  if (const std::string wrong = options.quality.Validate(); !wrong.empty()) {
    throw Error("invalid overlay quality: " + wrong, "dynaguide bench overlay",
                "correct --supersample, --volume-divisor or --volume-slice-mm");
  }
  overlay::SurfaceOverlay::Options mesh_options;
  mesh_options.supersample = options.quality.surface_supersample;
  overlay::SurfaceOverlay::Options texture_options = mesh_options;
  texture_options.lit = false;
  overlay::VolumeOverlay::Options volume_options;
  volume_options.slice_spacing_m = options.quality.volume_slice_spacing_m;
  volume_options.resolution_divisor = options.quality.volume_resolution_divisor;
  const auto mesh = scene.MakeMeshOverlay(mesh_options);
  const auto texture = scene.MakeTextureOverlay(texture_options);
  const auto volume = scene.MakeVolumeOverlay(volume_options);
  overlay::CompositorOptions compositor_options;
  compositor_options.layers = {{"texture", overlay::BlendMode::kAlpha},
                               {"volume", overlay::BlendMode::kInverseRealism},
                               {"mesh", overlay::BlendMode::kInverseRealism}};
  overlay::Compositor compositor(compositor_options);
  compositor.Offer(0, texture->Process(nodes[0], 0));
  compositor.Offer(1, volume->Process(nodes[0], 0));
  compositor.Offer(2, mesh->Process(nodes[0], 0));

  std::vector<OverlayBenchRecord> records;
  for (int threads : options.threads) {
    tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
    records.push_back(Time("mesh", threads, options.frames, available, [&](int j) { mesh->Process(nodes[j], j); }));
    records.push_back(Time("texture", threads, options.frames, available, [&](int j) { texture->Process(nodes[j], j); }));
    records.push_back(Time("volume", threads, options.frames, available, [&](int j) { volume->Process(nodes[j], j); }));
    cv::Mat composite;  // reused, as the run's pooled packets do
    records.push_back(Time("composite", threads, options.frames, available,
                           [&](int j) { compositor.Compose(video[j], j, &composite, nullptr); }));
    for (size_t i = records.size() - 4; i < records.size(); ++i) {
      records[i].width = video[0].cols;
      records[i].height = video[0].rows;
      if (progress)
        std::fprintf(stderr, "bench overlay: %s, %d thread%s: %.2f ms median\n", records[i].overlay.c_str(), threads,
                     threads > 1 ? "s" : "", records[i].ms_median);
    }
  }
  fs::remove_all(dir);
  return records;
}

void WriteOverlayBenchJson(const std::string& path, const std::vector<OverlayBenchRecord>& records) {
  std::vector<std::string> texts;
  for (const OverlayBenchRecord& r : records) {
    const nlohmann::ordered_json record = {{"overlay", r.overlay},
                                           {"threads", r.threads},
                                           {"width", r.width},
                                           {"height", r.height},
                                           {"frames", r.frames},
                                           {"ms_median", Significant(r.ms_median, 4)},
                                           {"ms_p95", Significant(r.ms_p95, 4)},
                                           {"fps", Significant(r.fps, 4)}};
    texts.push_back(JsonText(record, -1));
  }
  WriteBenchJson(path, texts);
}

std::string OverlayBenchTable(const std::vector<OverlayBenchRecord>& records) {
  std::string table =
      "| overlay | threads | size | ms median | ms p95 | fps |\n"
      "|---|---:|---|---:|---:|---:|\n";
  for (const OverlayBenchRecord& r : records) {
    char line[160];
    std::snprintf(line, sizeof line, "| %s | %d | %dx%d | %.2f | %.2f | %.0f |\n", r.overlay.c_str(), r.threads,
                  r.width, r.height, r.ms_median, r.ms_p95, r.fps);
    table += line;
  }
  return table;
}

}  // namespace dg::tools
