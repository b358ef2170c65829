#include "tools/overlay_quality_options.h"

#include <CLI/CLI.hpp>

#include "pipeline/overlay_stages.h"

namespace dg::tools {

void AddOverlayQualityOptions(CLI::App* command, pipeline::OverlayQuality* quality) {
  command->add_option("--supersample", quality->surface_supersample,
                      "Texture and meshes overlays: samples per pixel per axis (2 smooths edges at 4x the work)")
      ->check(CLI::Range(1, 4))
      ->capture_default_str();
  command->add_option("--volume-divisor", quality->volume_resolution_divisor,
                      "CT volume overlay drawn at 1/N of the image's resolution per axis, then resampled "
                      "(N divides the image's width and height)")
      ->check(CLI::Range(1, 8))
      ->capture_default_str();
  command
      ->add_option_function<double>(
          "--volume-slice-mm", [quality](double mm) { quality->volume_slice_spacing_m = mm * 1e-3; },
          "CT volume overlay's slice spacing, mm [0.1, 10] (default " +
              std::to_string(quality->volume_slice_spacing_m * 1e3).substr(0, 4) + ")")
      ->check(CLI::Range(0.1, 10.0));
}

}  // namespace dg::tools
