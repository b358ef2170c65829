#include "tools/track/front_end.h"

#include <algorithm>
#include <filesystem>

#include "sim/error.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;

bool IsImagePath(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const char* image : {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm"})
    if (ext == image) return true;
  return false;
}

// Left and right inputs given on the command line as a scene's video.
io::Scene::Video VideoOf(const FrontEndInput& input) {
  io::Scene::Video video;
  video.left = input.left;
  video.right = input.right;
  video.fps = input.fps;
  if (!IsImagePath(input.left)) return video;  // videos: a rate of 0 takes the container's
  video.layout = io::Scene::Video::Layout::kImageSequences;
  // One image pair is one frame at t = 0, whatever the rate. A sequence's
  // times need the rate it was recorded at: without one, capture refuses it.
  const bool single_pair = fs::is_regular_file(input.left) && fs::is_regular_file(input.right);
  if (single_pair && !(video.fps > 0)) video.fps = 1;
  return video;
}

}  // namespace

io::Scene FrontEndScene(const FrontEndInput& input) {
  io::Scene scene;
  if (!input.scene.empty()) {
    scene = io::ReadScene(input.scene);
    if (!input.left.empty() || !input.right.empty()) {
      throw Error("a scene and --left/--right given together", input.scene,
                  "give the scene (its video is read) or --left and --right with --calib, not both");
    }
    if (input.fps > 0) scene.video.fps = input.fps;
  } else {
    if (input.left.empty() || input.right.empty()) {
      throw Error("no input given", "dynaguide track", "give a scene file, or --left and --right");
    }
    scene.video = VideoOf(input);
    scene.path = "the command line";
  }
  if (!input.calibration.empty()) scene.calibration = input.calibration;
  if (!input.calibration_units.empty()) {
    scene.calibration.metres_per_unit = io::CalibrationMetresPerUnit(input.calibration_units, "--calib-units");
  }
  if (scene.calibration.empty()) {
    throw Error("no calibration given", "dynaguide track",
                "give --calib calib.yaml (made by dynaguide calibrate), or a stereo pair's files (--calib "
                "intrinsics.yml extrinsics.yml)");
  }
  // Cut after tracking: nothing to register, simulate or draw.
  scene.registration.reset();
  scene.simulation.reset();
  scene.preoperative.reset();
  scene.overlays.reset();
  return scene;
}

pipeline::FrontEndSettings FrontEndSettingsOf(const FrontEndInput& input) {
  pipeline::FrontEndSettings settings;
  settings.near_m = input.near_m;
  settings.far_m = input.far_m;
  settings.target_features = input.target_features;
  return settings;
}

}  // namespace dg::tools
