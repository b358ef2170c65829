#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "io/calibration.h"
#include "io/scene.h"
#include "pipeline/packet_stage.h"
#include "pipeline/simulation_stages.h"
#include "stages/overlay/compositor.h"
#include "stages/overlay/surface_overlay.h"

namespace dg::pipeline {

// The overlays of a run (paper section 2.7), in the frame's own path: the
// overlays stage draws every overlay from the frame's simulated state, and
// the composite stage lays those layers over the same frame, so that what is
// shown is the anatomy as it is in the frame it lies over, in both policies
// (docs/design.md#overlays). A stereo run (side-by-side video) draws and
// composes both eyes; a left-only run the left eye alone.

// Draws one frame's layer from the simulated nodes (scan frame).
using OverlayDraw = std::function<stages::overlay::OverlayLayer(const Eigen::Matrix3Xd& nodes_S, std::int64_t frame)>;
struct OverlayQuality;
// Builds an overlay's drawing through one eye at a quality, once the
// registration (the camera's pose, in the view) is known. Called once per eye
// (and again when a realtime run coarsens the quality): each drawing has
// buffers of its own, and allocates `layers_alive` layers up front (the most
// that are ever alive at once), so that drawing allocates none.
using OverlayFactory = std::function<OverlayDraw(const stages::overlay::LensView& view, int layers_alive,
                                                 const OverlayQuality& quality)>;

// How finely the overlays are drawn: one setting for a run's drawings and
// `dynaguide bench overlay`'s, so that the benchmark times what a run draws.
// The defaults fit all three overlays, the simulation and the front end into
// a 30 fps frame on two cores (docs/design.md#overlays).
struct OverlayQuality {
  int surface_supersample = 1;      // samples per pixel per axis of the texture and meshes (2: smooth edges, 4x the work)
  double volume_slice_spacing_m = 2e-3;  // the CT volume's slices (opacity-corrected, so a coarser spacing keeps the tissue's density)
  int volume_resolution_divisor = 2;     // the CT volume at 1/divisor of the image's resolution per axis

  std::string Validate() const;  // empty when valid
  std::string Describe() const;  // one line, for the run's log
  // The next coarser CT volume for a width x height image (twice the
  // divisor where that divides the image, 1.5 times the spacing), or false
  // when it is as coarse as a realtime run goes (divisor 8 or spacing beyond 5 mm).
  bool CoarsenVolume(int width, int height);
};

// overlays: packet.simulation (+ registration) -> packet.layers (and
// packet.layers_right in a stereo run), one per overlay in drawing order,
// each drawn from this frame's nodes, with each draw's span in
// packet.draw_{start,end}_steady_ns. Before the simulation starts the layers
// are empty. Stateful: a drawing reuses its buffers (one call at a time),
// and the drawings are built at the first registered frame.
class OverlaysAdapter final : public PacketStage {
 public:
  struct Options {
    io::StereoCalibration calibration;  // the lenses, with the rectification the graph applies
    bool right_eye = false;             // draw the right eye too
    // Layers of one drawing alive at once: one per packet in flight (a
    // packet releases its layers when the source refills it).
    int layers_alive = 2;
    // The registered pose, when the scene gives it: the drawings are built
    // here, before the first frame, rather than at the first registered one.
    std::optional<Eigen::Isometry3d> T_C_S;
    OverlayQuality quality;
    // Realtime: the drawings' share of a frame period on all cores (ms). If
    // the median of three frames' drawings exceeds it, the CT volume is
    // drawn more coarsely (OverlayQuality::CoarsenVolume) until they fit or
    // it is as coarse as it goes; each step is logged. 0: the quality stays
    // (offline, where the video must not depend on the machine's pace).
    double draw_budget_ms = 0;
  };
  // names, factories: one per overlay, in drawing order.
  // @throws dg::Error when names and factories differ in number,
  // layers_alive is below 1, or the quality is invalid.
  OverlaysAdapter(const Options& options, std::vector<std::string> names, std::vector<OverlayFactory> factories);
  const std::string& name() const override { return name_; }
  bool stateful() const override { return true; }
  bool parallel_inside() const override { return true; }
  void Process(FramePacket& packet) override;

  const std::vector<std::string>& overlay_names() const { return names_; }
  // The quality the overlays are drawn at now.
  const OverlayQuality& quality() const { return options_.quality; }

 private:
  // The eyes' drawings, through the lenses at the registered pose.
  void BuildDrawings(const Eigen::Isometry3d& T_C_S);
  // Realtime: one frame's drawing time against the budget.
  void FitToBudget(double draw_ms, const Eigen::Isometry3d& T_C_S);

  std::string name_ = "overlays";
  Options options_;
  std::vector<std::string> names_;
  std::vector<OverlayFactory> factories_;
  // Per overlay, the left eye's drawing then (stereo) the right's; empty until the pose is known.
  std::vector<std::array<OverlayDraw, 2>> drawings_;
  std::vector<double> recent_draw_ms_;  // realtime: the frames since the quality last changed
  bool fitted_ = false;                 // realtime: the quality is settled
};

// What the scene's overlays are, in drawing order: "texture" (surface_mesh
// with surface_texture, alpha-blended), "volume" (the CT, the first phase,
// through the cardiac transfer function) and "meshes" (internal_meshes, lit);
// the scene's overlays.order, or those its assets allow in that order.
struct OverlayPlan {
  stages::overlay::CompositorOptions compositor;
  std::vector<OverlayFactory> factories;  // one per compositor entry
};

// The surfaces the overlays draw, read from the scene's assets: the internal
// meshes, each in its own colour, and the surface mesh with its texture.
// @throws dg::Error for an unreadable mesh or texture.
std::vector<stages::overlay::OverlaySurface> InternalMeshSurfaces(const io::Scene::Overlays& assets);
stages::overlay::OverlaySurface TexturedSurface(const io::Scene::Overlays& assets);

// setup: the simulation the overlays draw (its mesh embeds them).
// @throws dg::Error for an overlay whose assets the scene lacks, or an unreadable asset.
OverlayPlan PlanOverlays(const io::Scene& scene, std::shared_ptr<const SimulationSetup> setup);

// composite: packet.raw.left + packet.layers -> packet.composite (with
// packet.layer_age_frames), and in a stereo run packet.raw.right +
// packet.layers_right -> packet.composite_right. Into the packet's own
// images, which the pooled packets keep from frame to frame. Before the
// simulation starts (no layers yet) the composite is the video frame.
// Stateless.
class CompositeAdapter final : public PacketStage {
 public:
  CompositeAdapter(std::shared_ptr<const stages::overlay::Compositor> compositor, bool right_eye);
  const std::string& name() const override { return name_; }
  bool stateful() const override { return false; }
  bool parallel_inside() const override { return true; }  // bands of rows
  void Process(FramePacket& packet) override;

 private:
  std::string name_ = "composite";
  std::shared_ptr<const stages::overlay::Compositor> compositor_;
  bool right_eye_;
};

}  // namespace dg::pipeline
