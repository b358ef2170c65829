#include "pipeline/scene_graph.h"

#include "io/h5_file.h"
#include "pipeline/front_end_stages.h"
#include "pipeline/scene_geometry.h"
#include "sim/error.h"
#include "sim/log.h"

namespace dg::pipeline {
namespace {

std::string SizeText(cv::Size size) { return std::to_string(size.width) + "x" + std::to_string(size.height); }

stages::CaptureStage::Options CaptureOptions(const io::Scene::Video& video) {
  stages::CaptureStage::Options options;
  options.left_path = video.left;
  options.right_path = video.right;
  options.fps = video.fps;
  options.expected_frames = video.frames;
  using Layout = io::Scene::Video::Layout;
  options.layout = video.layout == Layout::kSideBySide       ? stages::CaptureStage::Layout::kSideBySide
                   : video.layout == Layout::kImageSequences ? stages::CaptureStage::Layout::kImageSequences
                                                             : stages::CaptureStage::Layout::kTwoFiles;
  return options;
}

// Where the fiducials are in the first left frame: the scene's file, or the truth's first frame.
std::vector<Eigen::Vector2d> FirstFiducialPixels(const io::Scene& scene) {
  if (!scene.registration->fiducials_uv.empty()) return io::ReadFiducialPixels(scene.registration->fiducials_uv);
  if (scene.truth.empty()) {
    throw Error("the fiducials' first-frame pixels are not known", scene.path,
                "give registration.fiducials_uv: a file of u,v lines, one per scan fiducial (first left frame)");
  }
  io::H5Shape shape;
  const std::vector<double> uv = io::H5Reader(scene.truth).Read<double>("/fiducials/uv_left_px", &shape);
  std::vector<Eigen::Vector2d> first;
  for (size_t i = 0; shape.size() == 3 && i < shape[1]; ++i) first.emplace_back(uv[2 * i], uv[2 * i + 1]);
  return first;
}

std::unique_ptr<PacketStage> MakeRegisterStage(const io::Scene& scene, const io::StereoCalibration& calibration,
                                               const FrontEndSettings& settings) {
  if (!scene.preoperative) {
    throw Error("registration needs the scan (preoperative: period_s, phases, motion)", scene.path,
                "add a preoperative: block, or give registration.file");
  }
  stages::FiducialMotion motion = stages::ReadFiducialMotion(scene.preoperative->motion);
  if (motion.num_phases() != scene.preoperative->phases) {
    throw Error("the scan has " + std::to_string(motion.num_phases()) + " phases of fiducials but the scene says " +
                    std::to_string(scene.preoperative->phases),
                scene.path, "make preoperative.phases match the scan");
  }
  const std::vector<Eigen::Vector2d> first = FirstFiducialPixels(scene);
  if (static_cast<int>(first.size()) != motion.num_fiducials()) {
    throw Error(std::to_string(first.size()) + " first-frame pixels for " + std::to_string(motion.num_fiducials()) +
                    " scan fiducials",
                scene.path, "give one pixel per scan fiducial, in the scan's order");
  }
  stages::RegistrationStage::Options options;
  options.cycles = scene.registration->cycles;
  return std::make_unique<RegisterAdapter>(options, std::move(motion), calibration, scene.preoperative->period_s,
                                           first, settings.near_m, settings.far_m,
                                           scene.registration->live_phase);
}

// The scene's own registration places the tissue before a frame is read: the
// scan's fiducials (else the mesh) through it, against the depth range.
void CheckGivenPose(const io::Scene& scene, const io::Registration& given, const io::StereoCalibration& rectified,
                    const SimulationSetup* simulation, const FrontEndSettings& settings) {
  Eigen::Matrix3Xd points_S_m;
  std::string what;
  if (scene.preoperative) {
    const stages::FiducialMotion fiducials = stages::ReadFiducialMotion(scene.preoperative->motion);
    if (fiducials.num_phases() > 0) points_S_m = fiducials.positions_S_m.front();
    what = "the scan's fiducials, placed by registration.file,";
  }
  if (points_S_m.cols() == 0 && simulation) {
    points_S_m = simulation->mesh.X_m;
    what = "the mesh's nodes, placed by registration.file,";
  }
  if (points_S_m.cols() == 0) return;
  CheckWorkingDistance(DepthsInCamera(given.T_C_S, points_S_m), what, rectified,
                       settings.near_m, settings.far_m, scene.registration->file + " (through " + scene.path + ")",
                       "write the registration's T_C_S with its translation in metres (divide it by 1000 if it is "
                       "in millimetres)");
}

}  // namespace

SceneGraph BuildSceneGraph(const io::Scene& scene, const GraphOptions& options, const FrontEndSettings& settings,
                           const OverlaySettings& overlay_settings) {
  SceneGraph built;
  auto source = std::make_unique<CaptureSource>(CaptureOptions(scene.video), scene.video.rectified);
  // A calibration without an image size (OpenCV's stereo_calib sample writes none) takes the video's.
  built.calibration = io::ReadStereoCalibration(scene.calibration, io::ImageSize{source->size().width,
                                                                                 source->size().height});
  const cv::Size calibrated(built.calibration.left.width, built.calibration.left.height);
  if (source->size() != calibrated) {
    throw Error("the video is " + SizeText(source->size()) + " but the calibration is for " + SizeText(calibrated),
                scene.calibration.Describe(), "use the calibration of the camera and resolution that recorded the video");
  }

  std::vector<std::unique_ptr<PacketStage>> stages;
  if (scene.video.rectified) {
    if (!built.calibration.rectification) {
      throw Error("the scene says the video is rectified, but the calibration has no rectification (R1 R2 P1 P2 Q)",
                  scene.calibration.Describe(), "add the rectification that produced the video (dynaguide calibrate writes it)");
    }
  } else {
    auto rectify = std::make_shared<const stages::RectifyStage>(stages::RectifyStage::Options{}, built.calibration);
    built.calibration.rectification = rectify->rectification();
    stages.push_back(std::make_unique<RectifyAdapter>(rectify));
  }
  stages::FeatureTracker::Options tracking =
      stages::OptionsForDepthRange(built.calibration, settings.near_m, settings.far_m);
  tracking.detector.target_count = settings.target_features;
  stages.push_back(std::make_unique<TrackAdapter>(tracking, built.calibration));

  io::Scene with_defaults = scene;  // a simulation is registered over the default window unless the scene says
  if (with_defaults.simulation && !with_defaults.registration) with_defaults.registration = io::Scene::Registration{};
  if (with_defaults.registration) {
    if (!with_defaults.registration->file.empty()) {
      built.given_registration =
          std::make_shared<const io::Registration>(io::ReadRegistrationYaml(with_defaults.registration->file));
    } else {
      stages.push_back(MakeRegisterStage(with_defaults, built.calibration, settings));
      built.live_phase = with_defaults.registration->live_phase;
    }
  }
  std::unique_ptr<PacketStage> draw, composite;
  if (scene.simulation) {
    built.simulation = LoadSimulationSetup(scene);
    OverlayPlan overlays = PlanOverlays(scene, built.simulation);
    if (!overlays.factories.empty()) {
      Logger("pipeline").info("overlays drawn for every simulated frame: {}", overlay_settings.quality.Describe());
      OverlaysAdapter::Options drawing;
      drawing.calibration = built.calibration;
      drawing.right_eye = overlay_settings.right_eye;
      drawing.layers_alive = options.max_in_flight;
      drawing.quality = overlay_settings.quality;
      // Realtime, the drawings get half of each frame period on both cores;
      // the simulation, the composite and the next frame's front end the rest.
      if (options.policy == Policy::kRealtime) drawing.draw_budget_ms = 0.5e3 / scene.video.fps;
      if (built.given_registration) drawing.T_C_S = Eigen::Isometry3d(built.given_registration->T_C_S);
      for (const auto& entry : overlays.compositor.layers) built.overlay_names.push_back(entry.name);
      auto stage = std::make_unique<OverlaysAdapter>(drawing, built.overlay_names, std::move(overlays.factories));
      built.overlays_stage = stage.get();
      draw = std::move(stage);
      composite = std::make_unique<CompositeAdapter>(
          std::make_shared<const stages::overlay::Compositor>(overlays.compositor), overlay_settings.right_eye);
    }
    stages.push_back(std::make_unique<ConstraintAdapter>(built.simulation, built.given_registration));
    stages.push_back(std::make_unique<FemAdapter>(built.simulation));
  }
  if (built.given_registration) {
    CheckGivenPose(with_defaults, *built.given_registration, built.calibration, built.simulation.get(), settings);
  }
  if (draw) {
    stages.push_back(std::move(draw));
    stages.push_back(std::move(composite));
  }
  built.graph = std::make_unique<StageGraph>(std::move(source), std::move(stages), options);
  return built;
}

}  // namespace dg::pipeline
