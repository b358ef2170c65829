// `dynaguide run` and `dynaguide report` on the tiny phantom: the run log
// reads back through the HDF5 C API (not the writer's code) with the
// documented datasets, row counts and attributes; a run stopped by a failing
// stage leaves a readable log marked incomplete; the report recomputes the
// run's summary and its overlays' layer ages from the saved log. With --video-layout side_by_side the video
// and the snapshots show both eyes, each with its own eye's overlays.
#include <sched.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "io/registration_file.h"
#include "io/scene.h"
#include "pipeline/run_scene.h"
#include "pipeline/simulation_stages.h"
#include "sim/error.h"
#include "sim/stability.h"
#include "tests/support/h5_plain.h"
#include "tests/support/text_file.h"
#include "tests/support/tiny_phantom.h"
#include "tools/bench/machine_peaks.h"
#include "tools/bench/run_bench.h"
#include "tools/report/saved_run.h"
#include "tools/report/timing_plot.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;
using dg::testing::ReadText;
using dg::testing::TinyPhantomDir;
using namespace dg::testing::h5_plain;

std::int64_t CountFrames(const std::string& video_path) {
  cv::VideoCapture video(video_path);
  std::int64_t frames = 0;
  for (cv::Mat frame; video.read(frame);) ++frames;
  return frames;
}

cv::Mat VideoFrame(const std::string& video_path, int frame) {
  cv::VideoCapture video(video_path);
  cv::Mat image;
  for (int j = 0; j <= frame; ++j) REQUIRE(video.read(image));
  return image;
}

}  // namespace

TEST_CASE("run: the tiny phantom end to end, and its report", "[tools][integration]") {
  pipeline::RunOptions options;
  options.scene = TinyPhantomDir() + "/scene.yaml";
  options.out_dir = TinyPhantomDir() + "/run";
  options.threads = 2;
  options.progress = false;
  const pipeline::RunOutcome outcome = pipeline::RunScene(options);
  const int frames = 30;  // the tiny preset's video: 1 s at 30 fps
  REQUIRE(outcome.statistics.frames == frames);
  REQUIRE(outcome.statistics.complete);
  REQUIRE(CountFrames(outcome.video_path) == frames);
  REQUIRE(cv::VideoCapture(outcome.video_path).get(cv::CAP_PROP_FRAME_WIDTH) == 160);  // the left frame alone

  const hid_t file = H5Fopen(outcome.log_path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(IntAttribute(file, "/", "complete") == 1);
  CHECK(IntAttribute(file, "/", "threads") == 2);
  CHECK(StringAttribute(file, "/", "policy") == "offline");
  CHECK_FALSE(StringAttribute(file, "/", "version").empty());
  CHECK(StringAttribute(file, "/tracks/kind", "values") == "0 corner, 1 MSER");
  CHECK(StringAttribute(file, "/timings", "stage_names") ==
        "capture,rectify,track,register,constraints,simulate,overlays,composite,sink");
  // One row per stage per frame, in every column.
  for (const char* column : {"/timings/frame", "/timings/stage", "/timings/thread", "/timings/start_ns",
                             "/timings/end_ns"}) {
    CHECK(Rows(file, column) == static_cast<hsize_t>(frames) * 9);
  }
  CHECK(Rows(file, "/drops/frame") == 0);
  const hsize_t track_rows = Rows(file, "/tracks/id");
  CHECK(track_rows > static_cast<hsize_t>(frames) * 20);  // the tiny view holds a few dozen tracks
  CHECK(Rows(file, "/tracks/xyz_C_m") == track_rows);
  CHECK(StringDataset(file, "/scene") == ReadText(options.scene));  // verbatim

  // Registered over the first cycle (20 frames at 90 bpm), solved on frame 19,
  // then simulated from that frame to the end, and measured against the truth.
  const long long registered_at = IntAttribute(file, "/registration", "frame");
  CHECK(registered_at == 19);
  CHECK(Rows(file, "/registration/T_C_S") == 4);
  // The same registration as a file a scene can reuse, read back through its own reader.
  const io::Registration reused = io::ReadRegistrationYaml(outcome.registration_path);
  const std::vector<double> T_C_S = Doubles(file, "/registration/T_C_S");
  for (int k = 0; k < 16; ++k) CHECK(reused.T_C_S(k / 4, k % 4) == Approx(T_C_S[k]).margin(1e-12));
  const hsize_t simulated = static_cast<hsize_t>(frames - registered_at);
  CHECK(Rows(file, "/sim/frame") == simulated);
  CHECK(Rows(file, "/sim/sampled_nodes_S_m") == simulated);
  CHECK(IntAttribute(file, "/", "simulated_frames") == static_cast<long long>(simulated));
  CHECK(Rows(file, "/errors/frame") == simulated);
  // The whole system's error (registration from 160x120 video over one
  // cycle, tracking, combined simulation) within the paper's combined-mode
  // maxima (Table 1: internal 1.75 mm, surface 0.68 mm). A loose bound: the
  // tiny preset is coarse; the protocol measures the default phantom.
  for (double internal_max_mm : Doubles(file, "/errors/internal_max_mm")) CHECK(internal_max_mm < 1.75);
  for (double surface_mean_mm : Doubles(file, "/errors/surface_mean_mm")) CHECK(surface_mean_mm < 0.68);
  // The per-point surface column holds each frame's measured points and nothing else: as many
  // finite entries as surface_points, their largest the frame's surface_max_mm.
  const std::vector<double> surface_points = Doubles(file, "/errors/surface_points");
  const std::vector<double> surface_max_mm = Doubles(file, "/errors/surface_max_mm");
  const std::vector<double> surface_mm = Doubles(file, "/errors/surface_mm");
  const size_t truth_points = surface_mm.size() / surface_points.size();
  REQUIRE(truth_points * surface_points.size() == surface_mm.size());
  for (size_t row = 0; row < surface_points.size(); ++row) {
    int seen = 0;
    double largest = 0;
    for (size_t p = 0; p < truth_points; ++p) {
      const double e = surface_mm[row * truth_points + p];
      if (std::isnan(e)) continue;
      ++seen;
      largest = std::max(largest, e);
    }
    CHECK(seen == surface_points[row]);
    CHECK(largest == surface_max_mm[row]);
  }
  // The stability margin each frame reports is the run's step over the
  // mesh's critical step (its assembled estimate with the fixed nodes held),
  // and within the fraction the run's guard allows at the scene's Poisson's ratio.
  const io::Scene scene = io::ReadScene(options.scene);
  const std::shared_ptr<const pipeline::SimulationSetup> setup = pipeline::LoadSimulationSetup(scene);
  const double expected_margin = setup->options.dt_s / setup->stability.dt_critical_s;
  CHECK(expected_margin <= sim::DefaultStabilitySafety(scene.material.poissons_ratio));
  const std::vector<double> margins = Doubles(file, "/sim/dt_over_dt_critical");
  CHECK(margins.size() == simulated);
  for (double margin : margins) CHECK(margin == Approx(expected_margin).epsilon(1e-9));
  // Every frame composed; every simulated frame with each overlay's layer drawn from its own state.
  CHECK(Rows(file, "/composite/layer_age_frames") == static_cast<hsize_t>(frames));
  CHECK(StringAttribute(file, "/composite", "overlay_names") == "texture,volume,meshes");
  const std::vector<double> ages = Doubles(file, "/composite/layer_age_frames");
  CHECK(std::count(ages.begin(), ages.end(), 0.0) == static_cast<long>(3 * simulated));
  CHECK(std::count(ages.begin(), ages.end(), -1.0) == static_cast<long>(3 * (frames - simulated)));
  for (const std::string overlay : {"texture", "volume", "meshes"}) {
    CHECK(IntAttribute(file, "/overlay_timings", (overlay + "_drawn").c_str()) == static_cast<long long>(simulated));
  }
  CHECK(Rows(file, "/overlay_timings/frame") == static_cast<hsize_t>(3 * simulated));
  REQUIRE(outcome.overlays);
  CHECK(outcome.overlays->frames_with_layers == static_cast<std::int64_t>(simulated));
  CHECK(outcome.overlays->age_max_frames == 0);
  H5Fclose(file);

  SECTION("the report recomputes the run's summary from the log, and plots it") {
    const SavedRun saved = ReadSavedRun(outcome.log_path);
    REQUIRE(saved.statistics.frames == outcome.statistics.frames);
    REQUIRE(saved.statistics.stages.size() == outcome.statistics.stages.size());
    for (size_t s = 0; s < saved.statistics.stages.size(); ++s) {
      CHECK(saved.statistics.stages[s].median_ms == Approx(outcome.statistics.stages[s].median_ms));
      CHECK(saved.statistics.stages[s].p95_ms == Approx(outcome.statistics.stages[s].p95_ms));
    }
    CHECK(saved.statistics.latency_median_ms == Approx(outcome.statistics.latency_median_ms));
    CHECK(saved.statistics.realtime_factor == Approx(outcome.statistics.realtime_factor));
    const std::string plot = TinyPhantomDir() + "/run/timings.png";
    WriteTimingPlot(saved, plot);
    const cv::Mat image = cv::imread(plot);
    CHECK(image.cols == 1200);
    CHECK(image.rows == 600);

    // The overlays' layer ages: a plot of the same size, and per overlay a
    // summary that /composite, read through the plain C API, bears out.
    const std::string age_plot = TinyPhantomDir() + "/run/layer_age.png";
    WriteLayerAgePlot(saved, age_plot);
    const cv::Mat age_image = cv::imread(age_plot);
    CHECK(age_image.cols == 1200);
    CHECK(age_image.rows == 600);
    const hid_t log = H5Fopen(outcome.log_path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    REQUIRE(log >= 0);
    const std::vector<double> layer_ages = Doubles(log, "/composite/layer_age_frames");
    const hsize_t composed = Rows(log, "/composite/frame");
    H5Fclose(log);
    const std::vector<LayerAgeSummary> summaries = SummarizeLayerAges(saved);
    const std::vector<std::string> overlays = {"texture", "volume", "meshes"};
    REQUIRE(summaries.size() == overlays.size());
    for (size_t k = 0; k < overlays.size(); ++k) {
      std::vector<double> ages;  // the frames composed with the overlay's layer
      for (hsize_t row = 0; row < composed; ++row) {
        const double age = layer_ages[row * overlays.size() + k];
        if (age >= 0) ages.push_back(age);
      }
      REQUIRE(ages.size() == simulated);
      std::sort(ages.begin(), ages.end());
      const double median = ages.size() % 2 ? ages[ages.size() / 2]
                                            : (ages[ages.size() / 2 - 1] + ages[ages.size() / 2]) / 2;
      const LayerAgeSummary& summary = summaries[k];
      CHECK(summary.overlay == overlays[k]);
      CHECK(summary.composed_frames == static_cast<std::int64_t>(composed));
      CHECK(summary.frames_with_layer == static_cast<std::int64_t>(ages.size()));
      CHECK(summary.median_age_frames == median);
      CHECK(summary.max_age_frames == ages.back());
      CHECK(summary.Text() == overlays[k] + ": layer on " + std::to_string(ages.size()) + " of " +
                                  std::to_string(composed) + " composed frames, age median 0, max 0 frames");
    }

    // A run log without /composite (a run without overlays) has no layer ages to summarise.
    const std::string bare = TinyPhantomDir() + "/run/bare.h5";
    fs::copy_file(outcome.log_path, bare, fs::copy_options::overwrite_existing);
    const hid_t bare_file = H5Fopen(bare.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    REQUIRE(bare_file >= 0);
    REQUIRE(H5Ldelete(bare_file, "/composite", H5P_DEFAULT) >= 0);
    H5Fclose(bare_file);
    const SavedRun without_overlays = ReadSavedRun(bare);
    CHECK(without_overlays.overlay_names.empty());
    CHECK(SummarizeLayerAges(without_overlays).empty());
  }
}

// --video-layout side_by_side: the video read back through OpenCV is both
// eyes side by side (2W x H), every frame; a snapshot (a lossless PNG) from
// before the registration, when nothing is simulated yet, is the captured
// left frame beside the captured right one, to the pixel (composing no
// layers reproduces the frame exactly); every simulated frame carries every
// overlay's layer for both eyes.
TEST_CASE("run: side by side, the video and the snapshots show both eyes", "[tools][integration]") {
  pipeline::RunOptions options;
  options.scene = TinyPhantomDir() + "/scene.yaml";
  options.out_dir = TinyPhantomDir() + "/run_side_by_side";
  options.threads = 2;
  options.progress = false;
  options.video_layout = pipeline::VideoLayout::kSideBySide;
  const int snapshot = 5;  // registered on frame 19
  options.snapshots = {snapshot};
  const pipeline::RunOutcome outcome = pipeline::RunScene(options);
  const cv::Size eye(160, 120);  // the tiny preset's
  cv::VideoCapture video(outcome.video_path);
  REQUIRE(video.get(cv::CAP_PROP_FRAME_WIDTH) == 2 * eye.width);
  REQUIRE(video.get(cv::CAP_PROP_FRAME_HEIGHT) == eye.height);
  REQUIRE(CountFrames(outcome.video_path) == 30);

  const hid_t file = H5Fopen((options.out_dir + "/run.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  const std::vector<double> ages = Doubles(file, "/composite/layer_age_frames");
  H5Fclose(file);
  REQUIRE(outcome.simulated_frames > 0);
  CHECK(std::count(ages.begin(), ages.end(), 0.0) == 3 * outcome.simulated_frames);

  char name[64];
  std::snprintf(name, sizeof name, "/composite_%05d.png", snapshot);
  const cv::Mat picture = cv::imread(options.out_dir + name);
  REQUIRE(picture.size() == cv::Size(2 * eye.width, eye.height));
  const cv::Mat left = VideoFrame(TinyPhantomDir() + "/video/left.avi", snapshot);
  const cv::Mat right = VideoFrame(TinyPhantomDir() + "/video/right.avi", snapshot);
  REQUIRE(cv::norm(left, right, cv::NORM_L1) > eye.area());  // the eyes' frames differ
  REQUIRE(cv::norm(picture(cv::Rect({0, 0}, eye)), left, cv::NORM_INF) == 0);
  REQUIRE(cv::norm(picture(cv::Rect({eye.width, 0}, eye)), right, cv::NORM_INF) == 0);
}

// Offline, the video is the product and it is lossless: every frame is
// composed with layers drawn from its own simulated state, so the annotated
// video (decoded through OpenCV) is the same to the bit on one thread and on
// two, simulated frames with their overlays included.
TEST_CASE("run: offline, the annotated video is identical on one and two threads", "[tools][integration]") {
  std::vector<pipeline::RunOutcome> outcomes;
  for (int threads : {1, 2}) {
    pipeline::RunOptions options;
    options.scene = TinyPhantomDir() + "/scene.yaml";
    options.out_dir = TinyPhantomDir() + "/run_threads_" + std::to_string(threads);
    options.threads = threads;
    options.progress = false;
    outcomes.push_back(pipeline::RunScene(options));
  }
  REQUIRE(outcomes[0].simulated_frames > 0);
  REQUIRE(outcomes[1].simulated_frames == outcomes[0].simulated_frames);
  REQUIRE(outcomes[0].overlays->frames_with_layers == outcomes[0].simulated_frames);
  cv::VideoCapture one(outcomes[0].video_path), two(outcomes[1].video_path);
  cv::Mat a, b, last;
  int frames = 0, differing = 0;
  while (one.read(a)) {
    REQUIRE(two.read(b));
    differing += cv::norm(a, b, cv::NORM_INF) != 0;
    last = a.clone();
    ++frames;
  }
  REQUIRE_FALSE(two.read(b));
  REQUIRE(frames == CountFrames(outcomes[0].video_path));
  CHECK(differing == 0);
  // The last frame is simulated and shows the overlays: it differs from the frame as captured.
  CHECK(cv::norm(last, VideoFrame(TinyPhantomDir() + "/video/left.avi", frames - 1), cv::NORM_L1) > 0);

  // --show-age writes the layers' ages under the frame's label (rows 28-44)
  // and changes nothing else: below the JPEG blocks the label touches (16 x 16
  // colour blocks, so from row 48) the frames are the same to the bit.
  pipeline::RunOptions labelled;
  labelled.scene = TinyPhantomDir() + "/scene.yaml";
  labelled.out_dir = TinyPhantomDir() + "/run_show_age";
  labelled.threads = 2;
  labelled.progress = false;
  labelled.show_age = true;
  const cv::Mat aged = VideoFrame(pipeline::RunScene(labelled).video_path, frames - 1);
  const cv::Rect label(0, 16, last.cols, 32), below(0, 48, last.cols, last.rows - 48);
  CHECK(cv::norm(aged(label), last(label), cv::NORM_L1) > 0);
  CHECK(cv::norm(aged(below), last(below), cv::NORM_INF) == 0);
}

// The recording as image sequences whose eighth left image has another size:
// the capture stage fails at frame 7, the run throws naming stage and frame,
// and the log holds frames 0-6 and is marked incomplete.
TEST_CASE("run: a failing stage leaves a readable log marked incomplete", "[tools][integration]") {
  const std::string dir = TinyPhantomDir();
  fs::create_directories(dir + "/sequence");
  cv::VideoCapture left(dir + "/video/left.avi"), right(dir + "/video/right.avi");
  cv::Mat image;
  for (int frame = 0; frame < 12; ++frame) {
    char name[64];
    REQUIRE(left.read(image));
    if (frame == 7) cv::resize(image, image, {image.cols / 2, image.rows / 2});
    std::snprintf(name, sizeof name, "/sequence/left_%02d.png", frame);
    cv::imwrite(dir + name, image);
    REQUIRE(right.read(image));
    std::snprintf(name, sizeof name, "/sequence/right_%02d.png", frame);
    cv::imwrite(dir + name, image);
  }
  std::string text = ReadText(dir + "/scene.yaml");
  const std::string videos = "  left: video/left.avi\n  right: video/right.avi\n";
  text.replace(text.find(videos), videos.size(),
               "  layout: image_sequences\n  left: sequence/left_%02d.png\n  right: sequence/right_%02d.png\n");
  const std::string length = "  frames: 30\n";  // the sequence holds the recording's first 12
  REQUIRE(text.find(length) != std::string::npos);
  text.replace(text.find(length), length.size(), "  frames: 12\n");
  std::ofstream(dir + "/scene_sequence.yaml") << text;

  pipeline::RunOptions options;
  options.scene = dir + "/scene_sequence.yaml";
  options.out_dir = dir + "/run_failing";
  options.threads = 2;
  options.progress = false;
  REQUIRE_THROWS_WITH(pipeline::RunScene(options), Catch::Contains("stage 'capture' failed at frame 7"));

  const std::string log = options.out_dir + "/run.h5";
  const hid_t file = H5Fopen(log.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(IntAttribute(file, "/", "complete") == 0);
  CHECK_THAT(StringAttribute(file, "/", "error"), Catch::Contains("frame 7"));
  CHECK(Rows(file, "/timings/frame") == 7 * 9);  // capture ... simulate, overlays, composite, sink
  H5Fclose(file);
}

}  // namespace dg::tools

namespace dg::tools {

// `dynaguide bench run`'s record of a run says the machine it met just
// before: what the host took from the run's cores, and each core's own
// speed at loads and stores (docs/benchmarks.md). No speed is asserted.
TEST_CASE("bench run: a run's record holds the run and the machine it met", "[tools][integration]") {
  RunBenchOptions options;
  options.scene = TinyPhantomDir() + "/scene.yaml";
  options.policies = {pipeline::Policy::kOffline};
  options.threads = 2;
  options.repeats = 1;
  const std::vector<RunBenchRecord> records = RunRunBench(options, false);
  REQUIRE(records.size() == 1);
  const RunBenchRecord& r = records.front();
  CHECK(r.statistics.frames == io::ReadScene(options.scene).video.frames);
  CHECK(r.statistics.dropped == 0);  // offline: lossless
  CHECK(r.host.per_core_percent >= 0);
  CHECK(r.host.any_core_percent >= r.host.per_core_percent);
  REQUIRE(r.core_load_store_gb_s.size() == std::max(1u, std::thread::hardware_concurrency()));
  for (double gb_s : r.core_load_store_gb_s) CHECK((std::isnan(gb_s) || gb_s > 0));  // NaN: outside the cpuset
  CHECK(r.core_load_store_gb_s[sched_getcpu()] > 0);  // a core this thread runs on
  CHECK(RunBenchTable(records).find(CoreLoadStoreText(r.core_load_store_gb_s)) != std::string::npos);
}

}  // namespace dg::tools
