#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "sim/simulation_mode.h"

namespace dg::tools {

// One run log's errors against ground truth (its /errors, /registration and
// scene), as the evaluation tables need them.
struct RunErrors {
  std::string path;
  std::string scene_name;  // from the scene the run log holds
  sim::SimulationMode mode = sim::SimulationMode::kCombined;  // likewise
  std::string policy = "offline";  // the run's (root attribute policy; "offline" in a log without it)
  double fps = 0, period_s = 0;
  double realtime_factor = 0;    // seconds of video per wall second (frames / fps / wall_s)
  bool complete = false;
  double residual_mm_left = 0, residual_mm_right = 0;  // the registration's mean reprojection residuals
  bool registration_given = false;  // by the scene (a file), not registered from the run's video
  // Per simulated frame (rows of /errors).
  std::vector<std::int64_t> frame;
  std::vector<double> t_s;
  std::vector<std::int32_t> surface_points;
  std::vector<double> surface_mean_mm, surface_rms_mm, surface_max_mm;
  // The age of the layer the surface figures are shown in (the texture
  // overlay's) and of the one the internal figures are (the meshes', else the
  // volume's): 0 when composed over the frame from its own state, -1 when the
  // frame was composed without it. Empty in a log without them (one written
  // before the overlays were logged).
  std::vector<std::int64_t> surface_layer_age_frames, internal_layer_age_frames;
  int truth_surface_points = 0;     // the truth's surface points (seen or not)
  std::vector<double> surface_mm;   // [frame][truth point], NaN where unseen; empty in a log without it
  int internal_points = 0, fiducials = 0;
  std::vector<double> internal_mm;                          // [frame][point]
  std::vector<double> fiducial_sim_mm, fiducial_model_mm;  // [frame][fiducial]
  // Per frame with a live phase and a truth (rows of /phase, from the
  // registration to the run's end): |phase - true| of the live estimate and
  // of the registration's constant shift, in ms of the scan's period. Empty
  // without them.
  std::vector<double> phase_error_ms, registered_phase_error_ms;
};

// @throws dg::Error naming the file when it has no /errors (a run without
// simulation or ground truth) or no registration.
RunErrors ReadRunErrors(const std::string& run_h5);

// A run's errors over a window of frames: Table 1's figures (paper section 2.8).
struct ErrorFigures {
  int frames = 0;
  double surface_avg_mm = 0, surface_max_mm = 0, surface_rms_mm = 0;
  double internal_avg_mm = 0, internal_max_mm = 0, internal_rms_mm = 0;
  // The overlay as shown, what the surgeon sees: the same figures, pooled the
  // same way, over the rows whose layer was composed from the row's own state
  // (age 0). Each layer is drawn from its own frame's state, so they are the
  // state's over those rows. NaN when no row of the window had the layer (a
  // run without overlays, a log without layer ages).
  static constexpr double kUnknown = std::numeric_limits<double>::quiet_NaN();
  int shown_frames = 0;  // rows with both layers
  double shown_surface_avg_mm = kUnknown, shown_surface_max_mm = kUnknown, shown_surface_rms_mm = kUnknown;
  double shown_internal_avg_mm = kUnknown, shown_internal_max_mm = kUnknown, shown_internal_rms_mm = kUnknown;
  // shown_frames over the rows of the window (NaN when no run logged layer ages).
  double layer_present_fraction = kUnknown;
  std::vector<double> fiducial_sim_avg_mm, fiducial_model_avg_mm;  // Table 2: per fiducial
  // The paper's statistic: one typical surface feature followed through the
  // window. Per run, the point with the median RMS error among the points
  // seen in every frame of the window (the upper median of an even count);
  // the runs' courses pooled. typical_points: the points it was chosen from
  // (0 when no run has per-point errors, or no point was seen throughout:
  // then the typical figures are NaN).
  int typical_points = 0;
  double typical_avg_mm = 0, typical_max_mm = 0, typical_rms_mm = 0;
  // The cardiac phase against the truth over every frame with a live phase
  // (not only the window): the live estimate's and the constant shift's.
  int phase_frames = 0;
  double phase_error_mean_ms = 0, phase_error_max_ms = 0;
  double registered_phase_error_mean_ms = 0, registered_phase_error_max_ms = 0;
};

// The internal RMS error the error-against-run-time study weighs points by:
// the overlay's as shown, or the simulated state's when the runs drew no
// overlays (the shown figure is then NaN). The user sees the overlay.
double StudyInternalRmsMm(const ErrorFigures& figures);

// The rows of run's window: those whose frame lies in [first, first + frames)
// of its simulation (frames < 0: all). A realtime run that dropped frames has
// fewer rows than frames.
size_t WindowRows(const RunErrors& run, int frames);

// Over the rows of each run's window (WindowRows), pooled over the runs: each
// surface frame weighs by its point count, each internal point and fiducial once.
ErrorFigures Figures(const std::vector<const RunErrors*>& runs, int frames);

}  // namespace dg::tools
