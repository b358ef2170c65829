#pragma once

#include <optional>
#include <string>
#include <vector>

#include "io/calibration_source.h"
#include "sim/inverse_interval.h"
#include "sim/material.h"
#include "sim/precision.h"
#include "sim/simulation_mode.h"
#include "sim/time_step_policy.h"

namespace dg::io {

// A scene: one YAML file naming everything a run needs,
// as `dynaguide phantom` writes it. Paths in the file are relative to it and
// are resolved here to absolute ones; every named file must exist. Optional
// parts are absent in scenes that do not need them (no truth for a real
// recording, no preoperative data for surface-only runs).
struct Scene {
  std::string path;  // the scene file
  std::string text;  // verbatim, for the run log
  std::string name;

  struct Mesh {
    std::string file;
    double metres_per_unit = 1.0;
    std::string fixed_set = "base";
    std::string surface_set = "surface";
  } mesh;

  sim::Material material;

  struct Preoperative {
    double period_s = 0;
    int phases = 0;
    std::string motion;                   // HDF5 with /phases/node_displacement_m
    std::vector<std::string> ct_volumes;  // one MetaImage per phase
  };
  std::optional<Preoperative> preoperative;

  struct Overlays {
    std::string surface_mesh, surface_texture;
    std::vector<std::string> internal_meshes;
    std::string internal_points;  // "file.h5:/dataset"
    // The unit of the meshes' and internal_points' coordinates (`units:`,
    // as for mesh:; absent: metres), applied when they are read.
    double metres_per_unit = 1.0;
    // What a run draws, bottom first, of texture, volume and meshes; empty:
    // every overlay the assets allow, in that order.
    std::vector<std::string> order;
    // How the internal anatomy (volume, meshes) is laid over the video:
    // inverse_realism (under the tissue's own edges and highlights) or alpha.
    std::string blend = "inverse_realism";
  };
  std::optional<Overlays> overlays;

  // `calibration:` one file or a list of files (docs/formats/calibration.md),
  // and T's unit (`calibration_units:`; absent: metres).
  CalibrationSource calibration;
  std::string calibration_images;  // printf pattern with %s (left/right) and %d, optional

  struct Video {
    enum class Layout { kTwoFiles, kSideBySide, kImageSequences };
    Layout layout = Layout::kTwoFiles;
    std::string left, right;  // files, or printf patterns/globs of image sequences; right empty side by side
    double fps = 0;
    int frames = 0;
    bool rectified = false;  // the recording is already rectified: the graph has no rectify stage
  } video;

  // How the scan is registered to the video. With a
  // file (a YAML `dynaguide register --out` wrote) the run has no
  // registration stage; otherwise the run registers over its first `cycles`
  // scan periods, following the fiducials from their pixels in the first left
  // frame (`fiducials_uv`, a file of u,v lines; without it, the truth's).
  // Fiducial files carry no length unit: `fiducials_uv` is in pixels of the
  // first left frame, and the fiducials' scan positions are scan.h5's
  // /phases/fiducials_S_m, in metres.
  // Absent: registered by the run when the scene has a simulation.
  struct Registration {
    std::string file;
    double cycles = 3;
    std::string fiducials_uv;
    // After the registration, keep following the fiducials and estimate the
    // heart's phase every frame (docs/phase.md); false: the registration's
    // constant phase shift for the whole run. Needs a registration from the
    // run's video (not a file).
    bool live_phase = true;
  };
  std::optional<Registration> registration;

  // The image-constrained simulation; absent: the run
  // ends at tracking.
  struct Simulation {
    sim::SimulationMode mode = sim::SimulationMode::kCombined;
    double dt_s = 2e-4;
    double damping_per_s = 75;      // the paper's alpha
    double motion_smoothing = 0;    // the motion model's smoothing weight (0: interpolating)
    bool concurrent = true;         // inverse beside forward
    int inverse_interval_steps = sim::kDefaultInverseIntervalSteps;  // forward steps per level of recovered forces
    sim::Precision precision = sim::Precision::kFloat;  // float (as the paper's GPU solver) or double
    // A dt_s above the mesh's stable step: refuse (an error at scene load) or
    // substep (each step split into the fewest equal substeps that are stable).
    sim::TimeStepPolicy time_step_policy = sim::TimeStepPolicy::kRefuse;
    int sampled_nodes = 256;        // nodes logged per frame in /sim
    double max_tie_distance_m = 3e-3;  // features farther from every free surface node are not tied
    // A feature departing from the scan's prediction by more than the larger of
    // these (metres; times the frame's median departure) is left out that frame.
    double outlier_gate_min_m = 1e-3;
    double outlier_gate_scale = 3;
    // Features tied within this distance of each other are neighbours: one
    // departing from its neighbours' median by more than the gate is left out too.
    double outlier_neighbour_radius_m = 5e-3;
  };
  std::optional<Simulation> simulation;

  std::string truth;  // optional: ground truth HDF5
};

// @throws dg::Error naming the file, line and key path of an unknown key, a
// value of the wrong type, a missing required key, or a file that does not
// exist (with the resolved path).
Scene ReadScene(const std::string& path);

}  // namespace dg::io
