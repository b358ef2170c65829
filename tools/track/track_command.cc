// `dynaguide track`: the vision front end alone, tracks saved for scripts.
#include <cstdio>
#include <regex>

#include <CLI/CLI.hpp>

#include "pipeline/stop_request.h"
#include "sim/error.h"
#include "tools/commands.h"
#include "tools/track/track_run.h"

namespace dg::tools {
namespace {

// "A:B", "A:" or ":B" into [first, end); end -1 for "to the last frame".
void ParseFrameRange(const std::string& text, TrackRunOptions* options) {
  std::smatch match;
  if (!std::regex_match(text, match, std::regex(R"((\d*):(\d*))")))
    throw Error("--frames must be A:B (got '" + text + "')", "--frames", "write e.g. 0:100 for the first 100 frames");
  if (match[1].length() > 0) options->first_frame = std::stoll(match[1]);
  if (match[2].length() > 0) options->end_frame = std::stoll(match[2]);
}

}  // namespace

void AddTrackCommand(CLI::App& app) {
  auto options = std::make_shared<TrackRunOptions>();
  auto frames = std::make_shared<std::string>();
  CLI::App* command = app.add_subcommand("track", "Track surface points in stereo video (capture, rectify, track)");
  command->add_option("scene", options->input.scene, "Scene file (scene.yaml) naming the video and calibration");
  command->add_option("--left", options->input.left, "Left video, image sequence (printf or glob) or image");
  command->add_option("--right", options->input.right, "Right video, image sequence or image");
  command
      ->add_option("--calib", options->input.calibration.files,
                   "Stereo calibration (overrides the scene's): one file, or intrinsics.yml extrinsics.yml, or "
                   "left and right camera_info [and extrinsics.yml]")
      ->expected(1, 3);
  command->add_option("--calib-units", options->input.calibration_units,
                      "Unit of the calibration's T: m (default), cm, mm, um, or metres per unit (0.0025 for 2.5 mm squares)");
  command->add_option("--fps", options->input.fps, "Frame rate (needed for image sequences; overrides the scene's)");
  command->add_option("--near", options->input.near_m, "Nearest depth matched, metres (sets the disparity range)")
      ->capture_default_str();
  command->add_option("--far", options->input.far_m, "Farthest depth matched, metres")->capture_default_str();
  command->add_option("--features", options->input.target_features,
                      "Tracked features wanted (detection tops the tracks up when fewer than 90% are alive)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command->add_option("--out", options->out_h5, "Tracks as HDF5 (/tracks/..., written as it goes; root attribute complete = 1 at the end); its folder is created")->required();
  command->add_option("--csv", options->out_csv, "Tracks as CSV too");
  command->add_option("--frames", *frames, "Frame range A:B (B exclusive)");
  command->callback([options, frames] {
    if (!frames->empty()) ParseFrameRange(*frames, options.get());
    options->progress = true;
    pipeline::InstallStopOnSignals();  // a signal stops the run with its table finished (docs/interrupts.md)
    const TrackRunSummary s = RunTrack(*options);
    std::printf("tracked %d frames: %zu points, %lld tracks, %.1f ms/frame; saved %s%s%s\n", s.frames, s.rows,
                static_cast<long long>(s.tracks), s.ms_per_frame, options->out_h5.c_str(),
                options->out_csv.empty() ? "" : " and ", options->out_csv.c_str());
  });
}

}  // namespace dg::tools
