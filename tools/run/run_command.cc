// `dynaguide run`: the recorded stereo video of a scene through the TBB flow graph.
#include <cstdio>
#include <regex>

#include <CLI/CLI.hpp>

#include "pipeline/run_scene.h"
#include "pipeline/stop_request.h"
#include "sim/error.h"
#include "tools/commands.h"
#include "tools/overlay_quality_options.h"
#include "tools/phantom/phantom_cache.h"

namespace dg::tools {
namespace {

struct RunArguments {
  pipeline::RunOptions options;
  std::string policy = "offline";
  std::string video_layout = "left";
  std::string frames;
  std::vector<std::string> drop;
  bool print_graph = false;
  bool quiet = false;
  bool no_video = false;
  bool mesh_series = false, no_mesh_series = false;
};

// "A:B" (frames A to B-1), "A:" or ":B".
void ParseFrameRange(const std::string& text, pipeline::GraphOptions* graph) {
  std::smatch match;
  if (!std::regex_match(text, match, std::regex(R"((\d*):(\d*))"))) {
    throw Error("--frames must be A:B, A: or :B (got '" + text + "')", "--frames",
                "write e.g. 0:90 for the first 90 frames");
  }
  if (match[1].length()) graph->first_frame = std::stoll(match[1]);
  if (match[2].length()) graph->end_frame = std::stoll(match[2]);
}

// Each item "F" (frame F), "A:B" (frames A to B-1) or "A:B:S" (every S-th from A).
void ParseDropFrames(const std::vector<std::string>& items, pipeline::GraphOptions* graph) {
  for (const std::string& item : items) {
    std::smatch match;
    if (!std::regex_match(item, match, std::regex(R"((\d+)(?::(\d+)(?::(\d+))?)?)"))) {
      throw Error("--drop takes frames F, ranges A:B or A:B:S (got '" + item + "')", "--drop",
                  "write e.g. 41:61:2,70:80 for every other frame from 41 to 59 and frames 70 to 79");
    }
    const std::int64_t first = std::stoll(match[1]);
    const std::int64_t end = match[2].length() ? std::stoll(match[2]) : first + 1;
    const std::int64_t stride = match[3].length() ? std::stoll(match[3]) : 1;
    if (stride < 1) throw Error("--drop's stride must be at least 1 (got '" + item + "')", "--drop", "write A:B:S with S >= 1");
    for (std::int64_t frame = first; frame < end; frame += stride) graph->drop_frames.insert(frame);
  }
}

void RunRunCommand(RunArguments& args) {
  pipeline::RunOptions& options = args.options;
  options.graph.policy = pipeline::ParsePolicy(args.policy);
  if (!args.frames.empty()) ParseFrameRange(args.frames, &options.graph);
  ParseDropFrames(args.drop, &options.graph);
  options.progress = !args.quiet;
  options.video = !args.no_video;
  if (args.mesh_series || args.no_mesh_series) options.mesh_series = args.mesh_series;
  options.video_layout =
      args.video_layout == "side_by_side" ? pipeline::VideoLayout::kSideBySide : pipeline::VideoLayout::kLeft;
  if (options.scene.empty()) options.scene = DefaultScenePath(options.progress);
  if (args.print_graph) {
    std::fputs(pipeline::DescribeRunGraph(options).c_str(), stdout);
    return;
  }
  pipeline::InstallStopOnSignals();  // a signal stops the run with its outputs finished (docs/interrupts.md)
  const pipeline::RunOutcome outcome = pipeline::RunScene(options);
  std::printf("dynaguide run: %s\n%s", outcome.log_path.c_str(), outcome.statistics.Text().c_str());
  if (outcome.overlays) std::fputs(outcome.overlays->Text(outcome.statistics.wall_s).c_str(), stdout);
  if (!outcome.registration_path.empty()) {
    std::printf("registration: %s (a scene reuses it as registration: {file: ...})\n", outcome.registration_path.c_str());
  }
  if (!outcome.mesh_series_path.empty()) {
    std::printf("mesh series: %s (ParaView plays it: File > Open, then Play)\n", outcome.mesh_series_path.c_str());
  }
  if (!outcome.video_path.empty()) {
    std::printf("annotated video: %s (%lld frames dropped by the encoder)\n", outcome.video_path.c_str(),
                static_cast<long long>(outcome.video_frames_dropped));
  }
}

}  // namespace

void AddRunCommand(CLI::App& app) {
  auto args = std::make_shared<RunArguments>();
  CLI::App* command = app.add_subcommand(
      "run", "Stream a scene's recorded stereo video through the graph (no scene: the built-in default phantom)");
  command->add_option("scene", args->options.scene, "scene.yaml (default: the phantom, generated once into the cache)");
  command->add_option("--out", args->options.out_dir, "Output directory: run.h5 and annotated.avi")->capture_default_str();
  command->add_option("--threads", args->options.threads, "Threads for the whole run (default: all cores)")
      ->check(CLI::PositiveNumber);
  command->add_option("--policy", args->policy, "offline (lossless) | realtime (paced to the video, drops frames)")
      ->check(CLI::IsMember({"offline", "realtime"}))
      ->capture_default_str();
  command->add_option("--frames", args->frames, "Frame range A:B (frames A to B-1), A: or :B");
  command->add_option("--drop", args->drop,
                      "Offline: frames to drop at capture as the realtime policy would (F, A:B or A:B:S; "
                      "e.g. a live run's /drops, replayed)")
      ->delimiter(',');
  command->add_option("--in-flight", args->options.graph.max_in_flight, "Frames in flight at most")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command->add_option("--capture-buffer", args->options.graph.capture_buffer_frames,
                      "Realtime: frames the capture queue holds before the oldest is lost")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command->add_option("--near", args->options.front_end.near_m, "Nearest depth stereo matching searches, metres")
      ->capture_default_str();
  command->add_option("--far", args->options.front_end.far_m, "Farthest depth stereo matching searches, metres")
      ->capture_default_str();
  command->add_option("--features", args->options.front_end.target_features,
                      "Tracked features wanted (detection tops the tracks up when fewer than 90% are alive)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command->add_flag("--print-graph", args->print_graph, "Print the graph's nodes and edges and exit");
  command->add_flag("--no-video", args->no_video, "Do not write the annotated video");
  CLI::Option* mesh_series = command->add_flag(
      "--mesh-series", args->mesh_series,
      "Write the simulated mesh per frame as mesh_series.xmf + .h5 (XDMF, for ParaView): displacement, tied nodes "
      "and recovered forces (default: on when the frames read x the mesh's nodes are at most " +
          std::to_string(pipeline::kMeshSeriesDefaultNodeFrames) + ")");
  command->add_flag("--no-mesh-series", args->no_mesh_series, "Do not write the mesh series")->excludes(mesh_series);
  command->add_option("--video-layout", args->video_layout,
                      "left (the left frame, W x H) | side_by_side (left and right frames, 2W x H, each with its "
                      "eye's overlays: the right eye's are drawn only then); for the video and the snapshots")
      ->check(CLI::IsMember({"left", "side_by_side"}))
      ->capture_default_str();
  command->add_option("--snapshots", args->options.snapshots,
                      "Frames written as PNG, the overlays composed over the frame in the video's layout (e.g. 60,80)")
      ->delimiter(',');
  AddOverlayQualityOptions(command, &args->options.overlay_quality);
  command->add_flag("--show-age", args->options.show_age,
                    "Label each frame of the annotated video with its overlays' layer ages (frames since the "
                    "simulated state each layer was drawn from)");
  command->add_flag("--quiet", args->quiet, "No progress lines");
  command->callback([args] { RunRunCommand(*args); });
}

}  // namespace dg::tools
