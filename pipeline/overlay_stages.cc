#include "pipeline/overlay_stages.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <span>

#include <opencv2/imgcodecs.hpp>

#include "io/metaimage.h"
#include "io/registration_file.h"
#include "io/surface_mesh_reader.h"
#include "pipeline/scene_geometry.h"
#include "sim/error.h"
#include "stages/fem_stage.h"
#include "stages/overlay/surface_overlay.h"
#include "stages/overlay/transfer_function.h"
#include "stages/overlay/volume_overlay.h"

namespace dg::pipeline {
namespace {

namespace overlay = stages::overlay;

std::int64_t SteadyNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// Distinct colours for the internal structures (BGR).
const Eigen::Vector3f kStructureColors[] = {{0.95f, 0.55f, 0.25f}, {0.3f, 0.85f, 0.95f}, {0.5f, 0.95f, 0.4f}};

template <typename Overlay>
OverlayDraw DrawWith(std::shared_ptr<Overlay> overlay) {
  return [overlay](const Eigen::Matrix3Xd& nodes_S, std::int64_t frame) { return overlay->Process(nodes_S, frame); };
}

OverlayFactory MeshesFactory(const io::Scene& scene, std::shared_ptr<const SimulationSetup> setup) {
  const std::vector<overlay::OverlaySurface> surfaces = InternalMeshSurfaces(*scene.overlays);
  for (const overlay::OverlaySurface& surface : surfaces) CheckOverlayMeshSize(scene, surface.name, surface.mesh, setup->mesh);
  return [=](const overlay::LensView& view, int layers_alive) {
    overlay::SurfaceOverlay::Options options;
    options.reserved_layers = layers_alive;
    return DrawWith(std::make_shared<overlay::SurfaceOverlay>(options, setup->mesh, surfaces, view));
  };
}

OverlayFactory TextureFactory(const io::Scene& scene, std::shared_ptr<const SimulationSetup> setup) {
  const overlay::OverlaySurface surface = TexturedSurface(*scene.overlays);
  CheckOverlayMeshSize(scene, surface.name, surface.mesh, setup->mesh);
  overlay::SurfaceOverlay::Options options;
  options.lit = false;  // landmarks and annotations in their own colours
  return [=](const overlay::LensView& view, int layers_alive) {
    overlay::SurfaceOverlay::Options reserved = options;
    reserved.reserved_layers = layers_alive;
    return DrawWith(std::make_shared<overlay::SurfaceOverlay>(reserved, setup->mesh, std::vector{surface}, view));
  };
}

OverlayFactory VolumeFactory(const std::string& ct_file, std::shared_ptr<const SimulationSetup> setup) {
  // The first scan phase is the mesh's reference configuration.
  auto ct = std::make_shared<const io::VolumeI16>(io::ReadMetaImage<std::int16_t>(ct_file));
  overlay::VolumeOverlay::Options options;
  options.slice_spacing_m = 1e-3;  // above 15 frames/s on two cores (docs/benchmarks.md, bench overlay)
  return [=](const overlay::LensView& view, int layers_alive) {
    overlay::VolumeOverlay::Options reserved = options;
    reserved.reserved_layers = layers_alive;
    return DrawWith(std::make_shared<overlay::VolumeOverlay>(reserved, setup->mesh, ct,
                                                             overlay::TransferFunction::CardiacDefault(), view));
  };
}

}  // namespace

std::vector<overlay::OverlaySurface> InternalMeshSurfaces(const io::Scene::Overlays& assets) {
  std::vector<overlay::OverlaySurface> surfaces;
  for (const std::string& file : assets.internal_meshes) {
    overlay::OverlaySurface surface;
    surface.mesh = io::ReadSurfaceMesh(file, {assets.metres_per_unit, ""});
    surface.color_bgr = kStructureColors[surfaces.size() % std::size(kStructureColors)];
    surface.name = file;
    surfaces.push_back(std::move(surface));
  }
  return surfaces;
}

overlay::OverlaySurface TexturedSurface(const io::Scene::Overlays& assets) {
  overlay::OverlaySurface surface;
  surface.mesh = io::ReadSurfaceMesh(assets.surface_mesh, {assets.metres_per_unit, ""});
  surface.texture = cv::imread(assets.surface_texture, cv::IMREAD_COLOR);
  if (surface.texture.empty()) {
    throw Error("cannot read the surface texture", assets.surface_texture, "give a PNG or JPEG image");
  }
  surface.name = assets.surface_mesh;
  return surface;
}

OverlayBranch::OverlayBranch(std::string name, int index, OverlayFactory factory, OverlayEyes eyes,
                             const OverlayBranchOptions& options)
    : name_(std::move(name)),
      index_(index),
      factory_(std::move(factory)),
      eyes_(std::move(eyes)),
      // An eye's layers alive at once: the one being drawn, the mailbox's, and one per frame composing.
      layers_alive_(2 + options.composites_in_flight),
      ring_(options.ring_capacity) {
  if (options.composites_in_flight < 1) {
    throw Error("composites in flight " + std::to_string(options.composites_in_flight) + " is below 1",
                "overlay '" + name_ + "'", "give the graph's packets in flight");
  }
  if (options.T_C_S) BuildEyes(*options.T_C_S);
}

void OverlayBranch::BuildEyes(const Eigen::Isometry3d& T_C_S) {
  drawing_.push_back({factory_(overlay::LensView(eyes_.calibration.left, T_C_S), layers_alive_), eyes_.left, {}});
  if (eyes_.right) {
    drawing_.push_back({factory_(overlay::RightLensView(eyes_.calibration, T_C_S), layers_alive_), eyes_.right, {}});
  }
}

void OverlayBranch::Publish(const FramePacket& packet) {
  if (!packet.simulation || !packet.registration) return;
  Geometry geometry{packet.simulation, packet.registration, packet.index};
  ++published_;
  ring_.PushOrDrop(geometry);
  Wake();
}

void OverlayBranch::Drain() {
  // One draw of the newest geometry, then the turn passes to the next branch
  // (geometries arriving meanwhile wake this one again).
  Geometry geometry;
  if (!ring_.TryPopLatest(geometry)) return;
  const std::int64_t start = SteadyNowNs();
  if (drawing_.empty()) BuildEyes(Eigen::Isometry3d(geometry.registration->T_C_S));
  // Both eyes drawn before either is offered, so the eyes' composites show the same geometry.
  for (Eye& eye : drawing_) eye.layer = eye.draw(geometry.simulation->nodes_S_m, geometry.frame);
  for (Eye& eye : drawing_) eye.latest->Offer(index_, std::move(eye.layer));
  ++drawn_;
  std::lock_guard lock(timings_mutex_);
  timings_.push_back({geometry.frame, start, SteadyNowNs()});
}

std::vector<OverlayTiming> OverlayBranch::timings() const {
  std::lock_guard lock(timings_mutex_);
  return timings_;
}

OverlayPlan PlanOverlays(const io::Scene& scene, std::shared_ptr<const SimulationSetup> setup) {
  OverlayPlan plan;
  if (!scene.overlays) return plan;
  const io::Scene::Overlays& assets = *scene.overlays;
  const bool has_texture = !assets.surface_mesh.empty() && !assets.surface_texture.empty();
  const bool has_volume = scene.preoperative && !scene.preoperative->ct_volumes.empty();
  const bool has_meshes = !assets.internal_meshes.empty();
  std::vector<std::string> order = assets.order;
  if (order.empty()) {
    if (has_texture) order.push_back("texture");
    if (has_volume) order.push_back("volume");
    if (has_meshes) order.push_back("meshes");
  }
  const overlay::BlendMode anatomy_blend =
      assets.blend == "alpha" ? overlay::BlendMode::kAlpha : overlay::BlendMode::kInverseRealism;
  for (const std::string& name : order) {
    const bool available = name == "texture" ? has_texture : name == "volume" ? has_volume : has_meshes;
    if (!available) {
      throw Error("overlays.order asks for '" + name + "' but the scene has no asset for it", scene.path,
                  name == "texture"  ? "give overlays.surface_mesh and overlays.surface_texture"
                  : name == "volume" ? "give preoperative.ct"
                                     : "give overlays.internal_meshes");
    }
    if (name == "texture") {
      plan.compositor.layers.push_back({name, overlay::BlendMode::kAlpha});
      plan.factories.push_back(TextureFactory(scene, setup));
    } else if (name == "volume") {
      plan.compositor.layers.push_back({name, anatomy_blend});
      plan.factories.push_back(VolumeFactory(scene.preoperative->ct_volumes.front(), setup));
    } else {
      plan.compositor.layers.push_back({name, anatomy_blend});
      plan.factories.push_back(MeshesFactory(scene, setup));
    }
  }
  return plan;
}

CompositeAdapter::CompositeAdapter(std::shared_ptr<const overlay::Compositor> compositor,
                                   std::shared_ptr<const LatestLayers> left, std::shared_ptr<const LatestLayers> right)
    : compositor_(std::move(compositor)), left_(std::move(left)), right_(std::move(right)) {
  const int entries = static_cast<int>(compositor_->options().layers.size());
  for (const LatestLayers* eye : {left_.get(), right_.get()}) {
    if (eye && eye->overlays() != entries) {
      throw Error("an eye's newest layers hold " + std::to_string(eye->overlays()) + " overlays, the compositor composes " +
                      std::to_string(entries),
                  "composite stage", "build the eyes' mailboxes from the compositor's options");
    }
  }
}

void CompositeAdapter::Process(FramePacket& packet) {
  // On the stack: the frame allocates nothing here. The headers share the
  // layers' pixels, which keeps them alive while this frame composes.
  std::array<overlay::OverlayLayer, overlay::CompositorOptions::kMaxLayers> held;
  const std::span<overlay::OverlayLayer> layers(held.data(), compositor_->options().layers.size());
  left_->Take(layers);
  compositor_->Compose(packet.raw.left, packet.index, layers, &packet.composite, &packet.layer_age_frames);
  if (!right_) return;
  // The right eye's ages are not logged: its layers come from the same draws as the left's.
  right_->Take(layers);
  compositor_->Compose(packet.raw.right, packet.index, layers, &packet.composite_right, nullptr);
}

}  // namespace dg::pipeline
