#include "tools/overlay/overlay_snapshots.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>

#include "sim/error.h"
#include "tools/overlay/phantom_overlay_scene.h"

namespace dg::tools {
namespace {

namespace overlay = stages::overlay;

// The frame whose contraction is largest: the overlay is furthest from the reference there.
int PeakFrame(const PhantomOverlayScene& scene) {
  int best = 0;
  double best_motion = -1;
  for (int j = 0; j < scene.frames(); ++j) {
    const double motion = (scene.TrueNodes(j) - scene.mesh().X_m).colwise().norm().maxCoeff();
    if (motion > best_motion) {
      best_motion = motion;
      best = j;
    }
  }
  return best;
}

}  // namespace

std::string OverlaySnapshotSummary::Describe() const {
  char text[768];
  std::snprintf(text, sizeof text,
                "frame %d; %s\n"
                "surface overlay error (%d visible points): median %.3f px (%.4f mm), max %.3f px (%.4f mm)\n"
                "internal error (%d features): median %.4f mm, max %.4f mm\n",
                frame, embedding.c_str(), surface_px.count, surface_px.median, surface_mm.median, surface_px.max,
                surface_mm.max, internal_mm.count, internal_mm.median, internal_mm.max);
  std::string out = text;
  for (const std::string& file : files) out += "wrote " + file + "\n";
  return out;
}

OverlaySnapshotSummary WriteOverlaySnapshots(const OverlaySnapshotOptions& options) {
  const PhantomOverlayScene scene(options.scene);
  std::filesystem::create_directories(options.out_dir);
  OverlaySnapshotSummary summary;
  summary.frame = options.frame < 0 ? PeakFrame(scene) : options.frame;
  const Eigen::Matrix3Xd nodes = scene.TrueNodes(summary.frame);
  const cv::Mat video = scene.LeftFrame(summary.frame);

  overlay::SurfaceOverlay::Options mesh_options;
  mesh_options.supersample = options.supersample;
  mesh_options.opacity = 0.85f;
  overlay::SurfaceOverlay::Options texture_options = mesh_options;
  texture_options.lit = false;
  texture_options.opacity = 0.5f;
  overlay::VolumeOverlay::Options volume_options;
  volume_options.slice_spacing_m = options.slice_spacing_m;
  const auto mesh = scene.MakeMeshOverlay(mesh_options);
  const auto texture = scene.MakeTextureOverlay(texture_options);
  const auto volume = scene.MakeVolumeOverlay(volume_options);
  const overlay::OverlayLayer mesh_layer = mesh->Process(nodes, summary.frame);
  const overlay::OverlayLayer texture_layer = texture->Process(nodes, summary.frame);
  const overlay::OverlayLayer volume_layer = volume->Process(nodes, summary.frame);

  const auto write = [&](const std::string& name, const cv::Mat& image) {
    const std::string path = (std::filesystem::path(options.out_dir) / name).string();
    if (!cv::imwrite(path, image)) throw Error("cannot write " + name, path, "check the folder is writable");
    summary.files.push_back(path);
  };
  // Each mode alone over the frame, then all three as a run would compose them.
  using Entry = overlay::CompositorOptions::Entry;
  const auto compose = [&](std::vector<Entry> entries, std::vector<const overlay::OverlayLayer*> layers) {
    overlay::CompositorOptions compositor_options;
    compositor_options.layers = std::move(entries);
    overlay::Compositor compositor(compositor_options);
    for (size_t i = 0; i < layers.size(); ++i) compositor.Offer(static_cast<int>(i), *layers[i]);
    return compositor.Compose(video, summary.frame).bgr;
  };
  write("video.png", video);
  write("mesh.png", compose({{"mesh", overlay::BlendMode::kAlpha}}, {&mesh_layer}));
  write("mesh_inverse_realism.png", compose({{"mesh", overlay::BlendMode::kInverseRealism}}, {&mesh_layer}));
  write("volume.png", compose({{"volume", overlay::BlendMode::kAlpha}}, {&volume_layer}));
  write("volume_inverse_realism.png", compose({{"volume", overlay::BlendMode::kInverseRealism}}, {&volume_layer}));
  write("texture.png", compose({{"texture", overlay::BlendMode::kAlpha}}, {&texture_layer}));
  write("composite.png", compose({{"texture", overlay::BlendMode::kAlpha},
                                  {"volume", overlay::BlendMode::kInverseRealism},
                                  {"mesh", overlay::BlendMode::kInverseRealism}},
                                 {&texture_layer, &volume_layer, &mesh_layer}));
  cv::Mat saliency;
  overlay::Saliency(video, overlay::InverseRealismOptions{}).convertTo(saliency, CV_8U, 255);
  write("saliency.png", saliency);

  // Errors: the surface points and internal features embedded like the overlay's vertices.
  const overlay::LensView view = scene.LeftView();
  const PhantomTruthFrame truth = scene.Truth(summary.frame);
  const sim::Embedding surface_points(scene.mesh(), scene.surface_points_S());
  const sim::Embedding internal_points(scene.mesh(), scene.internal_points_S());
  const overlay::SurfaceOverlayError surface = overlay::MeasureSurfaceOverlayError(
      scene.calibration().left, view.T_C_S() * surface_points.Rebuild(nodes), truth.surface_uv_left_px,
      truth.surface_C, truth.surface_visible_left);
  summary.surface_px = overlay::Summarize(surface.error_px);
  summary.surface_mm = overlay::Summarize(surface.error_mm);
  summary.internal_mm =
      overlay::Summarize(overlay::InternalErrorMm(view.T_C_S() * internal_points.Rebuild(nodes), truth.internal_C));
  summary.embedding = "texture overlay: " + texture->embedding().Describe();
  return summary;
}

}  // namespace dg::tools
