#include "tools/overlay/phantom_overlay_scene.h"

#include <opencv2/videoio.hpp>

#include "io/gmsh_reader.h"
#include "io/h5_file.h"
#include "pipeline/overlay_stages.h"
#include "sim/error.h"
#include "tools/phantom/phantom_spec.h"

namespace dg::tools {
namespace {

namespace overlay = stages::overlay;

// Columns of a frame-major [frames, count, dims] dataset at one frame.
template <int Dims>
Eigen::Matrix<double, Dims, Eigen::Dynamic> FrameColumns(const std::vector<double>& data, int frame, Eigen::Index count) {
  return Eigen::Map<const Eigen::Matrix<double, Dims, Eigen::Dynamic>>(data.data() + frame * count * Dims, Dims, count);
}

}  // namespace

PhantomOverlayScene::PhantomOverlayScene(const std::string& scene_path) : scene_(io::ReadScene(scene_path)) {
  const std::string where = "overlay scene " + scene_path;
  if (scene_.truth.empty() || !scene_.overlays || !scene_.preoperative || scene_.preoperative->ct_volumes.empty())
    throw Error("the scene has no ground truth, overlays or CT", where,
                "use a scene written by `dynaguide phantom` (truth, overlays and preoperative.ct)");
  mesh_ = io::ReadGmsh(scene_.mesh.file, scene_.mesh.metres_per_unit);
  calibration_ = io::ReadStereoCalibration(scene_.calibration);
  const io::H5Reader truth(scene_.truth);
  const Eigen::Matrix4d T_C_S = truth.ReadMatrix("/T_C_S");
  T_C_S_ = Eigen::Isometry3d(T_C_S);
  // The motion's shape comes from the preset; each frame's state from the truth.
  const phantom::PhantomSpec spec = phantom::PresetSpec(truth.ReadAttribute<std::string>("/", "preset"));
  motion_ = std::make_unique<phantom::HeartMotion>(spec, 0.0);
  const std::vector<double> activation = truth.Read<double>("/frames/activation");
  const std::vector<double> sway = truth.Read<double>("/frames/sway");
  for (size_t j = 0; j < activation.size(); ++j) states_.push_back({activation[j], sway[j]});
  surface_points_S_ = truth.ReadMatrix("/surface_points/X_S_m").transpose();
  internal_points_S_ = truth.ReadMatrix("/internal_points/X_S_m").transpose();
  surface_xyz_C_ = truth.Read<double>("/surface_points/xyz_C_m");
  surface_uv_left_ = truth.Read<double>("/surface_points/uv_left_px");
  surface_visible_left_ = truth.Read<std::uint8_t>("/surface_points/visible_left");
  surface_uv_right_ = truth.Read<double>("/surface_points/uv_right_px");
  surface_visible_right_ = truth.Read<std::uint8_t>("/surface_points/visible_right");
  internal_xyz_C_ = truth.Read<double>("/internal_points/xyz_C_m");
}

Eigen::Matrix3Xd PhantomOverlayScene::TrueNodes(int frame) const {
  if (frame < 0 || frame >= frames())
    throw Error("frame " + std::to_string(frame) + " is outside the truth's " + std::to_string(frames()) + " frames",
                scene_.truth, "ask for a frame the phantom recorded");
  Eigen::Matrix3Xd nodes(3, mesh_.num_nodes());
  for (int a = 0; a < mesh_.num_nodes(); ++a) nodes.col(a) = motion_->Deform(mesh_.X_m.col(a), states_[frame]);
  return nodes;
}

PhantomTruthFrame PhantomOverlayScene::Truth(int frame) const {
  TrueNodes(frame);  // checks the frame
  const Eigen::Index surface = surface_points_S_.cols(), internal = internal_points_S_.cols();
  PhantomTruthFrame truth;
  truth.surface_C = FrameColumns<3>(surface_xyz_C_, frame, surface);
  truth.surface_uv_left_px = FrameColumns<2>(surface_uv_left_, frame, surface);
  truth.surface_uv_right_px = FrameColumns<2>(surface_uv_right_, frame, surface);
  truth.surface_visible_left.assign(surface_visible_left_.begin() + frame * surface,
                                    surface_visible_left_.begin() + (frame + 1) * surface);
  truth.surface_visible_right.assign(surface_visible_right_.begin() + frame * surface,
                                     surface_visible_right_.begin() + (frame + 1) * surface);
  truth.internal_C = FrameColumns<3>(internal_xyz_C_, frame, internal);
  return truth;
}

cv::Mat PhantomOverlayScene::LeftFrame(int frame) const {
  cv::VideoCapture video(scene_.video.left);
  cv::Mat image;
  for (int j = 0; j <= frame; ++j) {
    if (!video.read(image))
      throw Error("the video has no frame " + std::to_string(frame), scene_.video.left, "ask for an earlier frame");
  }
  return image;
}

overlay::LensView PhantomOverlayScene::LeftView() const { return overlay::LensView(calibration_.left, T_C_S_); }

overlay::LensView PhantomOverlayScene::RightView() const { return overlay::RightLensView(calibration_, T_C_S_); }

std::unique_ptr<overlay::SurfaceOverlay> PhantomOverlayScene::MakeMeshOverlay(
    const overlay::SurfaceOverlay::Options& options) const {
  return std::make_unique<overlay::SurfaceOverlay>(options, mesh_, pipeline::InternalMeshSurfaces(*scene_.overlays),
                                                   LeftView());
}

std::unique_ptr<overlay::SurfaceOverlay> PhantomOverlayScene::MakeTextureOverlay(
    const overlay::SurfaceOverlay::Options& options) const {
  return std::make_unique<overlay::SurfaceOverlay>(
      options, mesh_, std::vector<overlay::OverlaySurface>{pipeline::TexturedSurface(*scene_.overlays)}, LeftView());
}

std::unique_ptr<overlay::VolumeOverlay> PhantomOverlayScene::MakeVolumeOverlay(
    const overlay::VolumeOverlay::Options& options) const {
  // Phase 0 (end-diastole) is the mesh's reference configuration.
  auto ct =
      std::make_shared<const io::VolumeI16>(io::ReadMetaImage<std::int16_t>(scene_.preoperative->ct_volumes.front()));
  return std::make_unique<overlay::VolumeOverlay>(options, mesh_, ct, overlay::TransferFunction::CardiacDefault(),
                                                  LeftView());
}

}  // namespace dg::tools
