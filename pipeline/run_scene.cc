#include "pipeline/run_scene.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <optional>

#include <opencv2/imgcodecs.hpp>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include "io/output_folder.h"
#include "io/registration_file.h"
#include "io/run_log.h"
#include "io/scene.h"
#include "pipeline/annotated_video.h"
#include "pipeline/error_log.h"
#include "pipeline/machine_info.h"
#include "pipeline/mesh_series_sink.h"
#include "pipeline/overlay_log.h"
#include "pipeline/phase_log.h"
#include "pipeline/run_log_sink.h"
#include "pipeline/simulation_log.h"
#include "pipeline/stop_request.h"
#include "stages/register/fiducial_motion.h"
#include "sim/error.h"
#include "sim/log.h"
#include "sim/progress.h"

namespace dg::pipeline {
namespace {

namespace fs = std::filesystem;

const std::string& ScenePath(const RunOptions& options) {
  if (options.scene.empty()) {
    throw Error("no scene given to run", "RunOptions::scene", "name a scene file (docs/formats/scene.md)");
  }
  return options.scene;
}

SceneGraph BuildRunGraph(const io::Scene& scene, const RunOptions& options) {
  OverlaySettings overlays;
  overlays.right_eye = options.video_layout == VideoLayout::kSideBySide;
  overlays.quality = options.overlay_quality;
  return BuildSceneGraph(scene, options.graph, options.front_end, overlays);
}

// Frames the run will take from the source, for progress: the range, cut by the recording's length.
std::int64_t FramesInRange(const GraphOptions& graph, int recording_frames) {
  const std::int64_t end = graph.end_frame >= 0 ? std::min<std::int64_t>(graph.end_frame, recording_frames)
                                                : recording_frames;
  return std::max<std::int64_t>(0, end - graph.first_frame);
}

// Every snapshot names a frame the run reads, or none would be written for it.
void CheckSnapshots(const RunOptions& options, int recording_frames) {
  const std::int64_t end = options.graph.first_frame + FramesInRange(options.graph, recording_frames);
  for (std::int64_t frame : options.snapshots) {
    if (frame < options.graph.first_frame || frame >= end) {
      throw Error("--snapshots names frame " + std::to_string(frame) + ", outside the frames this run reads (" +
                      std::to_string(options.graph.first_frame) + " to " + std::to_string(end - 1) + ")",
                  "--snapshots", "name frames from " + std::to_string(options.graph.first_frame) + " to " +
                                     std::to_string(end - 1));
    }
  }
}

// Whether the run writes the mesh series: as asked, else when frames x nodes
// stays within kMeshSeriesDefaultNodeFrames.
// @throws dg::Error when asked for in a scene without simulation.
bool WantsMeshSeries(const RunOptions& options, const SceneGraph& built, const std::string& scene_path,
                     int recording_frames) {
  if (!built.simulation) {
    if (options.mesh_series.value_or(false)) {
      throw Error("--mesh-series asks for the simulated mesh, and the scene has no simulation", scene_path,
                  "add a simulation: block to the scene, or leave out --mesh-series");
    }
    return false;
  }
  if (options.mesh_series) return *options.mesh_series;
  const std::int64_t node_frames = FramesInRange(options.graph, recording_frames) * built.simulation->mesh.num_nodes();
  const bool on = node_frames <= kMeshSeriesDefaultNodeFrames;
  Logger("pipeline").info("mesh series {}: {} frames x {} nodes is {} the default's bound of {} ({} to choose)",
                     on ? "written" : "not written", FramesInRange(options.graph, recording_frames),
                     built.simulation->mesh.num_nodes(), on ? "within" : "above", kMeshSeriesDefaultNodeFrames,
                     on ? "--no-mesh-series" : "--mesh-series");
  return on;
}

}  // namespace

std::vector<std::string> RunOutputNames() {
  return {"run.h5",          "run.h5.part",         "annotated.avi",  "registration.yaml",
          "composite_*.png", "mesh_series.xmf",     "mesh_series.xmf.tmp", "mesh_series.h5"};
}

std::string DescribeRunGraph(const RunOptions& options) {
  const io::Scene scene = io::ReadScene(ScenePath(options));
  return BuildRunGraph(scene, options).graph->Describe();
}

RunOutcome RunScene(const RunOptions& options) {
  const int threads = options.threads > 0 ? options.threads : tbb::info::default_concurrency();
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
  const io::Scene scene = io::ReadScene(ScenePath(options));
  SceneGraph built = BuildRunGraph(scene, options);
  const PacketSource& source = built.graph->source();
  CheckSnapshots(options, source.frame_count());
  const bool write_mesh_series = WantsMeshSeries(options, built, scene.path, source.frame_count());

  std::vector<std::string> inputs;
  if (scene.registration && !scene.registration->file.empty()) inputs.push_back(scene.registration->file);
  const io::OutputFolderClaim claim(options.out_dir, "dynaguide run", RunOutputNames(), inputs);
  if (!claim.removed().empty()) {
    std::string names;
    for (const std::string& name : claim.removed()) names += (names.empty() ? "" : ", ") + name;
    Logger("pipeline").info("removed what an earlier run left in {}: {}", options.out_dir, names);
  }
  RunOutcome outcome;
  outcome.log_path = (fs::path(options.out_dir) / "run.h5").string();
  io::RunLog log(outcome.log_path, scene.text,
                 {DG_VERSION, PolicyName(options.graph.policy), DescribeMachine(threads), threads, source.fps()},
                 built.graph->stage_names());

  std::vector<RunLogSink::Consumer> consumers;
  SimulationLog simulation_log(log, built.simulation, built.given_registration);
  consumers.push_back([&](const FramePacket& packet) { simulation_log.Consume(packet); });
  std::optional<PhaseLog> phase_log;
  if (built.live_phase) {
    phase_log.emplace(log, scene.truth);
    consumers.push_back([&](const FramePacket& packet) { phase_log->Consume(packet); });
  }
  std::optional<ErrorLog> error_log;
  if (built.simulation && !scene.truth.empty()) {
    error_log.emplace(log, scene.truth, built.simulation->mesh, built.calibration.left,
                      scene.preoperative ? stages::ReadFiducialMotion(scene.preoperative->motion)
                                         : stages::FiducialMotion{},
                      built.overlay_names);
    consumers.push_back([&](const FramePacket& packet) { error_log->Consume(packet); });
  }
  std::optional<MeshSeriesSink> mesh_series;
  if (write_mesh_series) {
    mesh_series.emplace((fs::path(options.out_dir) / "mesh_series").string(), built.simulation);
    consumers.push_back([&](const FramePacket& packet) { mesh_series->Consume(packet); });
  }
  std::optional<OverlayLog> overlay_log;
  if (!built.overlay_names.empty()) {
    overlay_log.emplace(log, built.overlay_names);
    consumers.push_back([&](const FramePacket& packet) { overlay_log->Consume(packet); });
  }
  std::optional<AnnotatedVideo> video;
  if (options.video) {
    outcome.video_path = (fs::path(options.out_dir) / "annotated.avi").string();
    const cv::Size size(built.calibration.left.width, built.calibration.left.height);
    video.emplace(outcome.video_path, source.fps(), size, options.video_layout, options.graph.policy,
                  options.show_age ? built.overlay_names : std::vector<std::string>{});
    video->Start();
    consumers.push_back([&video](const FramePacket& packet) { video->Add(packet); });
  }
  if (!options.snapshots.empty()) {
    consumers.push_back([&options](const FramePacket& packet) {
      if (std::find(options.snapshots.begin(), options.snapshots.end(), packet.index) == options.snapshots.end()) return;
      char name[64];
      std::snprintf(name, sizeof name, "composite_%05lld.png", static_cast<long long>(packet.index));
      const std::string path = (fs::path(options.out_dir) / name).string();
      cv::Mat picture;
      ArrangePicture(packet, options.video_layout, &picture);
      if (!cv::imwrite(path, picture)) {
        throw Error("cannot write the snapshot", path, "check the output directory is writable");
      }
    });
  }
  Progress progress("run", static_cast<double>(FramesInRange(options.graph, source.frame_count())), options.progress);
  std::int64_t done = 0;
  const auto start = std::chrono::steady_clock::now();
  consumers.push_back([&](const FramePacket&) {
    const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    char rate[64];
    std::snprintf(rate, sizeof rate, "%.1f frames/s", ++done / std::max(elapsed_s, 1e-9));
    progress.Update(static_cast<double>(done), rate);
  });

  RunLogSink sink(log, std::move(consumers));
  const GraphRunResult result = built.graph->Run(sink);
  progress.Finish();
  if (overlay_log) {
    overlay_log->Finish(result.start_steady_ns, built.overlays_stage->quality().Describe());
    outcome.overlays = overlay_log->summary();
  }
  if (video) {
    try {
      video->Close();
    } catch (const Error& e) {
      // The encoder failed after the sink's last frame (a full disk). A run
      // that failed already keeps its first error.
      if (result.complete) {
        log.Finish(false, e.what());
        throw;
      }
      Logger("pipeline").warn("the annotated video could not be finished: {}", e.what());
    }
    outcome.video_frames_dropped = static_cast<std::int64_t>(video->dropped());
  }
  outcome.statistics = Summarize(sink.timings(), built.graph->stage_names(), result.frames_dropped,
                                           result.wall_s, source.fps(), result.complete);
  log.file().WriteAttribute("/", "frames", result.frames_done);
  log.file().WriteAttribute("/", "frames_dropped", result.frames_dropped);
  log.file().WriteAttribute("/", "wall_s", result.wall_s);
  log.file().WriteAttribute("/", "video_frames_dropped", outcome.video_frames_dropped);
  outcome.simulated_frames = simulation_log.simulated_frames();
  if (simulation_log.registration() && !built.given_registration) {
    // What the register stage found, for a scene to reuse (registration: {file: ...}).
    outcome.registration_path = (fs::path(options.out_dir) / "registration.yaml").string();
    io::WriteRegistrationYaml(outcome.registration_path, *simulation_log.registration());
  }
  log.file().WriteAttribute("/", "simulated_frames", outcome.simulated_frames);
  if (mesh_series) {
    outcome.mesh_series_path = mesh_series->xmf_path();
    try {
      mesh_series->Finish(result.complete);
    } catch (const Error& e) {
      // The run log still records how the run ended; a complete run fails for the series.
      if (result.complete) {
        log.Finish(false, e.what());
        throw;
      }
      Logger("pipeline").warn("the mesh series could not be marked incomplete: {}", e.what());
    }
  }
  if (result.complete && built.simulation && outcome.simulated_frames == 0) {
    Logger("pipeline").warn("the video ended before the registration window was full: nothing was simulated "
                       "(register over fewer cycles with registration.cycles, or give registration.file)");
  }
  log.Finish(result.complete, result.error);
  if (!result.complete && result.stop_signal != 0) {
    throw Interrupted(result.stop_signal, result.error, outcome.log_path,
                                "the frames read are in " + options.out_dir +
                                    " (marked complete = 0); run again for the whole recording");
  }
  if (!result.complete) {
    throw Error(result.error, outcome.log_path,
                "the frames before the failure are in " + options.out_dir + " (marked complete = 0)");
  }
  return outcome;
}

}  // namespace dg::pipeline
