#include "pipeline/scene_graph.h"

#include "pipeline/front_end_stages.h"
#include "sim/error.h"

namespace dg::pipeline {
namespace {

std::string SizeText(cv::Size size) { return std::to_string(size.width) + "x" + std::to_string(size.height); }

stages::CaptureStage::Options CaptureOptions(const io::Scene::Video& video) {
  stages::CaptureStage::Options options;
  options.left_path = video.left;
  options.right_path = video.right;
  options.fps = video.fps;
  using Layout = io::Scene::Video::Layout;
  options.layout = video.layout == Layout::kSideBySide       ? stages::CaptureStage::Layout::kSideBySide
                   : video.layout == Layout::kImageSequences ? stages::CaptureStage::Layout::kImageSequences
                                                             : stages::CaptureStage::Layout::kTwoFiles;
  return options;
}

}  // namespace

SceneGraph BuildSceneGraph(const io::Scene& scene, const GraphOptions& options, const FrontEndSettings& settings) {
  SceneGraph built;
  built.calibration = io::ReadStereoCalibration(scene.calibration);
  auto source = std::make_unique<CaptureSource>(CaptureOptions(scene.video), scene.video.rectified);
  const cv::Size calibrated(built.calibration.left.width, built.calibration.left.height);
  if (source->size() != calibrated) {
    throw Error("the video is " + SizeText(source->size()) + " but the calibration is for " + SizeText(calibrated),
                scene.calibration, "use the calibration of the camera and resolution that recorded the video");
  }

  std::vector<std::unique_ptr<PacketStage>> stages;
  if (scene.video.rectified) {
    if (!built.calibration.rectification) {
      throw Error("the scene says the video is rectified, but the calibration has no rectification (R1 R2 P1 P2 Q)",
                  scene.calibration, "add the rectification that produced the video (dynaguide calibrate writes it)");
    }
  } else {
    auto rectify = std::make_shared<const stages::RectifyStage>(stages::RectifyStage::Options{}, built.calibration);
    built.calibration.rectification = rectify->rectification();
    stages.push_back(std::make_unique<RectifyAdapter>(rectify));
  }
  stages.push_back(std::make_unique<TrackAdapter>(
      stages::OptionsForDepthRange(built.calibration, settings.near_m, settings.far_m), built.calibration));
  built.graph = std::make_unique<StageGraph>(std::move(source), std::move(stages), options);
  return built;
}

}  // namespace dg::pipeline
