#include "pipeline/overlay_stages.h"

#include <algorithm>
#include <chrono>

#include <fmt/format.h>

#include <opencv2/imgcodecs.hpp>

#include "io/metaimage.h"
#include "io/registration_file.h"
#include "io/surface_mesh_reader.h"
#include "pipeline/scene_geometry.h"
#include "sim/error.h"
#include "sim/log.h"
#include "sim/statistics.h"
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
  // Embedded once, before the first frame: at the registration only the view remains to build.
  const auto embedding = overlay::SurfaceOverlay::Embed(setup->mesh, surfaces);
  return [=](const overlay::LensView& view, int layers_alive, const OverlayQuality& quality) {
    overlay::SurfaceOverlay::Options options;
    options.supersample = quality.surface_supersample;
    options.reserved_layers = layers_alive;
    return DrawWith(std::make_shared<overlay::SurfaceOverlay>(options, embedding, surfaces, view));
  };
}

OverlayFactory TextureFactory(const io::Scene& scene, std::shared_ptr<const SimulationSetup> setup) {
  const std::vector<overlay::OverlaySurface> surfaces{TexturedSurface(*scene.overlays)};
  CheckOverlayMeshSize(scene, surfaces[0].name, surfaces[0].mesh, setup->mesh);
  const auto embedding = overlay::SurfaceOverlay::Embed(setup->mesh, surfaces);
  return [=](const overlay::LensView& view, int layers_alive, const OverlayQuality& quality) {
    overlay::SurfaceOverlay::Options options;
    options.lit = false;  // landmarks and annotations in their own colours
    options.supersample = quality.surface_supersample;
    options.reserved_layers = layers_alive;
    return DrawWith(std::make_shared<overlay::SurfaceOverlay>(options, embedding, surfaces, view));
  };
}

OverlayFactory VolumeFactory(const std::string& ct_file, std::shared_ptr<const SimulationSetup> setup) {
  // The first scan phase is the mesh's reference configuration.
  auto ct = std::make_shared<const io::VolumeI16>(io::ReadMetaImage<std::int16_t>(ct_file));
  return [=](const overlay::LensView& view, int layers_alive, const OverlayQuality& quality) {
    overlay::VolumeOverlay::Options options;
    options.slice_spacing_m = quality.volume_slice_spacing_m;
    options.resolution_divisor = quality.volume_resolution_divisor;
    options.reserved_layers = layers_alive;
    return DrawWith(std::make_shared<overlay::VolumeOverlay>(options, setup->mesh, ct,
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

OverlaysAdapter::OverlaysAdapter(const Options& options, std::vector<std::string> names,
                                 std::vector<OverlayFactory> factories)
    : options_(options), names_(std::move(names)), factories_(std::move(factories)) {
  if (names_.size() != factories_.size()) {
    throw Error(std::to_string(names_.size()) + " overlay names for " + std::to_string(factories_.size()) +
                    " drawings",
                "overlays stage", "give one name per overlay (PlanOverlays)");
  }
  if (options_.layers_alive < 1) {
    throw Error("layers alive " + std::to_string(options_.layers_alive) + " is below 1", "overlays stage",
                "give the graph's packets in flight");
  }
  if (const std::string wrong = options_.quality.Validate(); !wrong.empty()) {
    throw Error("invalid overlay quality: " + wrong, "overlays stage",
                "correct --supersample, --volume-divisor or --volume-slice-mm");
  }
  if (options_.T_C_S) BuildDrawings(*options_.T_C_S);
}

void OverlaysAdapter::BuildDrawings(const Eigen::Isometry3d& T_C_S) {
  const overlay::LensView left(options_.calibration.left, T_C_S);
  std::optional<overlay::LensView> right;
  if (options_.right_eye) right.emplace(overlay::RightLensView(options_.calibration, T_C_S));
  drawings_.clear();
  for (const OverlayFactory& factory : factories_) {
    std::array<OverlayDraw, 2>& eyes = drawings_.emplace_back();
    eyes[0] = factory(left, options_.layers_alive, options_.quality);
    if (right) eyes[1] = factory(*right, options_.layers_alive, options_.quality);
  }
}

void OverlaysAdapter::FitToBudget(double draw_ms, const Eigen::Isometry3d& T_C_S) {
  // Three frames' median, so that one slow frame (a page fault) does not
  // coarsen the drawings for the whole run, and few enough that the frames
  // drawn too slowly while it is found do not pile up into drops.
  constexpr size_t kFrames = 3;
  recent_draw_ms_.push_back(draw_ms);
  if (recent_draw_ms_.size() < kFrames) return;
  const double median_ms = sim::Median(recent_draw_ms_);
  recent_draw_ms_.clear();
  if (median_ms <= options_.draw_budget_ms) {
    fitted_ = true;
    Logger("pipeline").info("realtime: the overlays take {:.1f} ms a frame, within their {:.1f} ms share: {}",
                            median_ms, options_.draw_budget_ms, options_.quality.Describe());
    return;
  }
  const OverlayQuality before = options_.quality;
  if (!options_.quality.CoarsenVolume(options_.calibration.left.width, options_.calibration.left.height)) {
    fitted_ = true;
    Logger("pipeline").warn("realtime: the overlays take {:.1f} ms a frame, above their {:.1f} ms share, at the "
                            "coarsest volume ({}); frames the graph cannot keep up with are dropped whole",
                            median_ms, options_.draw_budget_ms, before.Describe());
    return;
  }
  Logger("pipeline").info("realtime: the overlays take {:.1f} ms a frame, above their {:.1f} ms share: now {}",
                          median_ms, options_.draw_budget_ms, options_.quality.Describe());
  BuildDrawings(T_C_S);
}

void OverlaysAdapter::Process(FramePacket& packet) {
  const size_t count = factories_.size();
  packet.layers.resize(count);
  packet.draw_start_steady_ns.assign(count, 0);
  packet.draw_end_steady_ns.assign(count, 0);
  if (options_.right_eye) packet.layers_right.resize(count);
  if (!packet.simulation || !packet.registration) return;  // nothing simulated yet: the frame as it is
  const bool first = drawings_.empty();
  if (first) BuildDrawings(Eigen::Isometry3d(packet.registration->T_C_S));
  const Eigen::Matrix3Xd& nodes_S = packet.simulation->nodes_S_m;
  // One overlay after the other, each on every core (its tiles): each draw's
  // time is then its own, as `bench overlay` measures it.
  for (size_t k = 0; k < count; ++k) {
    packet.draw_start_steady_ns[k] = SteadyNowNs();
    packet.layers[k] = drawings_[k][0](nodes_S, packet.index);
    if (options_.right_eye) packet.layers_right[k] = drawings_[k][1](nodes_S, packet.index);
    packet.draw_end_steady_ns[k] = SteadyNowNs();
  }
  // The first frame's draws touch every buffer for the first time: not a frame like the others.
  if (options_.draw_budget_ms > 0 && !fitted_ && !first) {
    FitToBudget((packet.draw_end_steady_ns.back() - packet.draw_start_steady_ns.front()) * 1e-6,
                Eigen::Isometry3d(packet.registration->T_C_S));
  }
}

std::string OverlayQuality::Validate() const {
  if (surface_supersample < 1 || surface_supersample > 4) return "the surfaces' supersampling must be within [1, 4]";
  if (!(volume_slice_spacing_m >= 1e-4 && volume_slice_spacing_m <= 1e-2)) {
    return "the volume's slice spacing must be within [0.1, 10] mm";
  }
  if (volume_resolution_divisor < 1 || volume_resolution_divisor > 8) {
    return "the volume's resolution divisor must be within [1, 8]";
  }
  return {};
}

bool OverlayQuality::CoarsenVolume(int width, int height) {
  if (volume_resolution_divisor >= 8 || volume_slice_spacing_m > 5e-3) return false;
  const int divisor = 2 * volume_resolution_divisor;
  if (width % divisor == 0 && height % divisor == 0) volume_resolution_divisor = divisor;
  volume_slice_spacing_m *= 1.5;
  return true;
}

std::string OverlayQuality::Describe() const {
  return fmt::format("surfaces at {} sample(s) per pixel per axis, the CT volume at 1/{} resolution in {:.2g} mm slices",
                     surface_supersample, volume_resolution_divisor, volume_slice_spacing_m * 1e3);
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

CompositeAdapter::CompositeAdapter(std::shared_ptr<const overlay::Compositor> compositor, bool right_eye)
    : compositor_(std::move(compositor)), right_eye_(right_eye) {}

void CompositeAdapter::Process(FramePacket& packet) {
  // The overlays stage sized the lists to the compositor's entries, empty layers included.
  compositor_->Compose(packet.raw.left, packet.index, packet.layers, &packet.composite, &packet.layer_age_frames);
  // The right eye's ages are not logged: its layers come from the same frame's state as the left's.
  if (right_eye_) compositor_->Compose(packet.raw.right, packet.index, packet.layers_right, &packet.composite_right,
                                       nullptr);
}

}  // namespace dg::pipeline
