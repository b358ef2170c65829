#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "io/calibration.h"
#include "io/scene.h"
#include "pipeline/latest_layers.h"
#include "pipeline/packet_stage.h"
#include "pipeline/simulation_stages.h"
#include "pipeline/spsc_ring.h"
#include "pipeline/stage_graph.h"
#include "stages/overlay/compositor.h"
#include "stages/overlay/surface_overlay.h"

namespace dg::pipeline {

// The overlays of a run (paper section 2.7): each one a
// side branch fed by the FEM stage through its own SPSC ring, drawing the
// newest geometry at its own pace and handing its layer to its eye's
// newest-layer mailbox (pipeline/latest_layers.h); the composite stage lays
// the newest layers over each video frame. A stereo run (side-by-side video)
// has a mailbox per eye, and each branch draws both eyes; a left-only run
// draws and composes the left eye alone.

// Draws one frame's layer from the simulated nodes (scan frame).
using OverlayDraw = std::function<stages::overlay::OverlayLayer(const Eigen::Matrix3Xd& nodes_S, std::int64_t frame)>;
// Builds an overlay's drawing through one eye, once the registration (the
// camera's pose, in the view) is known. Called once per eye: each drawing
// has buffers of its own, and allocates `layers_alive` layers up front (the
// most that are ever alive at once), so that drawing allocates none.
using OverlayFactory = std::function<OverlayDraw(const stages::overlay::LensView& view, int layers_alive)>;

// Where the overlays' layers go: each eye's newest-layer mailbox, shared by
// every branch and the composite stage (the right one only in a stereo run),
// and the calibration the lenses are built from.
struct OverlayEyes {
  io::StereoCalibration calibration;
  std::shared_ptr<LatestLayers> left;
  std::shared_ptr<LatestLayers> right;  // null: the left eye alone
};

struct OverlayBranchOptions {
  std::size_t ring_capacity = 2;  // geometries waiting (more are dropped and counted)
  // Frames the composite stage composes at once (the graph's packets in
  // flight), each holding a layer of every overlay until it is composed.
  int composites_in_flight = 2;
  // The registered pose, when the scene gives it: the overlays are built with
  // the branch, before the first frame, rather than at the first draw.
  std::optional<Eigen::Isometry3d> T_C_S;
};

// When an overlay drew a frame (steady clock), for the run log's /overlay_timings.
struct OverlayTiming {
  std::int64_t frame = 0;
  std::int64_t start_steady_ns = 0, end_steady_ns = 0;
};

class OverlayBranch final : public SideBranch {
 public:
  // index: the overlay's entry in the compositor's options (and the eyes' mailboxes).
  OverlayBranch(std::string name, int index, OverlayFactory factory, OverlayEyes eyes,
                const OverlayBranchOptions& options = {});

  const std::string& name() const override { return name_; }
  const std::string& fed_by() const override { return fed_by_; }
  void Drain() override;

  // Producer side (the FEM stage, serial): never blocks.
  void Publish(const FramePacket& packet);

  // Geometries handed over, dropped (ring full, or skipped for a newer one) and drawn.
  std::int64_t published() const { return published_; }
  std::size_t dropped() const { return ring_.dropped(); }
  std::int64_t drawn() const { return drawn_.load(); }
  // Every draw's timing so far (both eyes' in a stereo run; call after the run).
  std::vector<OverlayTiming> timings() const;

 private:
  struct Geometry {
    std::shared_ptr<const stages::FemFrameOutput> simulation;
    std::shared_ptr<const io::Registration> registration;
    std::int64_t frame = -1;
  };
  struct Eye {
    OverlayDraw draw;
    std::shared_ptr<LatestLayers> latest;
    stages::overlay::OverlayLayer layer;  // drawn, not yet offered
  };

  // The eyes' drawings, through the lenses at the registered pose.
  void BuildEyes(const Eigen::Isometry3d& T_C_S);

  std::string name_, fed_by_ = "simulate";
  int index_;
  OverlayFactory factory_;
  OverlayEyes eyes_;
  int layers_alive_;
  std::vector<Eye> drawing_;  // left, then right in a stereo run; empty until the first geometry
  SpscRing<Geometry> ring_;
  std::int64_t published_ = 0;
  std::atomic<std::int64_t> drawn_{0};
  mutable std::mutex timings_mutex_;
  std::vector<OverlayTiming> timings_;
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

// composite: packet.raw.left + the left eye's newest layers -> packet.composite
// (with packet.layer_age_frames), and in a stereo run packet.raw.right + the
// right eye's -> packet.composite_right. Into the packet's own images, which
// the pooled packets keep from frame to frame. Stateless.
class CompositeAdapter final : public PacketStage {
 public:
  // left, right: the eyes' mailboxes, with as many overlays as the
  // compositor's options have entries; right null for a left-only run.
  // @throws dg::Error when a mailbox's overlays are not the compositor's entries.
  CompositeAdapter(std::shared_ptr<const stages::overlay::Compositor> compositor,
                   std::shared_ptr<const LatestLayers> left, std::shared_ptr<const LatestLayers> right = nullptr);
  const std::string& name() const override { return name_; }
  bool stateful() const override { return false; }
  void Process(FramePacket& packet) override;

 private:
  std::string name_ = "composite";
  std::shared_ptr<const stages::overlay::Compositor> compositor_;
  std::shared_ptr<const LatestLayers> left_, right_;
};

}  // namespace dg::pipeline
