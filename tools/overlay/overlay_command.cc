// `dynaguide overlay`: the overlays of a phantom scene at one frame, as PNGs to look at.
#include <cstdio>

#include <CLI/CLI.hpp>

#include "tools/commands.h"
#include "tools/overlay/overlay_snapshots.h"

namespace dg::tools {

void AddOverlayCommand(CLI::App& app) {
  auto options = std::make_shared<OverlaySnapshotOptions>();
  CLI::App* command = app.add_subcommand(
      "overlay", "Draw a phantom's overlays (meshes, CT volume, texture) under its true motion and measure their error");
  command->add_option("scene", options->scene, "A phantom's scene.yaml")->required();
  command->add_option("--out", options->out_dir, "Folder for the PNGs")->required();
  command->add_option("--frame", options->frame, "Video frame (-1: peak contraction)")->capture_default_str();
  command->add_option("--supersample", options->supersample, "Samples per pixel per axis (1-4)")->capture_default_str();
  command->add_option("--slice-spacing", options->slice_spacing_m, "Volume slice spacing, metres")->capture_default_str();
  command->callback([options] { std::fputs(WriteOverlaySnapshots(*options).Describe().c_str(), stdout); });
}

}  // namespace dg::tools
