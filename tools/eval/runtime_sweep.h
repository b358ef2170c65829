#pragma once

#include <optional>
#include <string>
#include <vector>

#include "pipeline/run_statistics.h"
#include "sim/precision.h"
#include "tools/eval/run_errors.h"

namespace dg::tools {

// `dynaguide eval runtime`: error against run time. A sweep over
// what trades accuracy for speed on a phantom with ground truth: the mesh's
// resolution, the time step, the tracker's target feature count, the
// threads and the simulation's precision. Each point is an independent
// `dynaguide run` of the whole graph (registered from the video, combined
// mode, the scene's overlays, offline policy, no video file) writing its own
// log under DIR/runs/<point>/run.h5 beside point.yaml (what the point is);
// every figure of the report is read back from those files.

// One configuration.
struct SweepPoint {
  int target_tets = 0;  // 0: the scene's own mesh; else a mesh of the phantom's shape at about this size
  double dt_s = 2e-4;
  int target_features = 500;  // the tracker's (pipeline::FrontEndSettings)
  int threads = 2;
  sim::Precision precision = sim::Precision::kFloat;  // the simulation's (scene key simulation.precision)
  // Unique and stable, the run's directory: e.g. "tets8000_dt0.20ms_f500_threads2"
  // ("tets-own_..." for the scene's own mesh; "_double" appended in double).
  std::string Name() const;
};

// One-factor-at-a-time around a baseline, plus a few combinations (a full
// factorial of 5 meshes x 5 steps x 3 feature counts x 2 thread counts is 150
// runs; this is 17):
//   baseline: the phantom's own 8k mesh, dt 0.2 ms, 500 features, 2 threads;
//   mesh 2k, 4k, 16k, 32k; dt 0.1, 0.3, 0.4, 0.5 ms; 250 and 1000 features; 1 thread;
//   double precision;
//   combinations toward real time: 4k at 0.4 ms on 2 and 1 threads, 2k at
//   0.5 ms, 16k at 0.3 ms.
// Steps above a mesh's limit are refused by the guard and reported, not run
// (on the default phantom the own 8k mesh's dt_cr is about 0.40 ms, so 0.4
// and 0.5 ms are refused there).
// Quick (tests): the tiny phantom's own mesh at dt 0.1, 0.2, 0.4 ms (and 0.2
// in double) and a 3k mesh at 0.2 ms, all with 500 features on 2 threads.
std::vector<SweepPoint> DesignSweep(bool quick);

// What the guard (sim/tled_solver.h, TimeStepPolicy::kRefuse, the policy of
// the run's coupled simulation, which cannot substep) makes of a point,
// decided before running it from the assembled stability estimate of its mesh.
struct PointPlan {
  SweepPoint point;
  std::string scene;  // the point's scene file (beside the phantom's)
  int tets = 0, nodes = 0;
  double dt_critical_s = 0;
  double safety = 0;     // the solver's allowed fraction of dt_critical_s for the scene's material
  bool refused = false;  // dt above the solver's safety fraction of dt_critical_s: not run
};

struct RuntimeOptions {
  std::string scene;   // empty: the preset's phantom, seed 1, from the cache
  bool quick = false;  // DesignSweep(true) on the tiny preset
  std::string out_dir = "out/runtime";
  std::string emit_jobs;  // write one `dynaguide run` line per point here instead of running
  // What each job line calls: the dynaguide command gives its own absolute path
  // (JobProgramPath), so the jobs need no PATH.
  std::string program = "dynaguide";
  double cycles = 3;      // the error window from the simulation's start, as the protocol's
  bool progress = true;
};

// A point read back from its directory.
struct PointResult {
  PointPlan plan;
  bool ran = false;   // its run log was read
  std::string error;  // why its run failed, when it did
  ErrorFigures errors;
  double realtime_factor = 0;                     // the whole run's: video seconds per wall second
  double simulating_realtime_factor = 0;          // over the simulated frames only (see SimulatingRealtimeFactor)
  std::vector<pipeline::StageStatistics> stages;  // per stage over the simulated frames: median, p95, mean ms
  std::string machine;                            // the run log's: CPU, cores, threads used, SIMD, compiler
  double load_average = 0;  // the 1-minute load when the point started locally; 0 for a job run elsewhere
  bool pareto = false;      // non-dominated in (StudyInternalRmsMm, simulating real-time factor)
};

struct RuntimeResult {
  std::string scene_name;
  int window_frames = 0;              // of every run's errors; -1 when no point ran
  std::vector<PointResult> points;    // in design order (DesignSweep's, or directory order from logs)
  std::optional<size_t> recommended;  // RecommendForRealTime
};

// Plans, then runs every stable point one at a time (or, with emit_jobs,
// lists them), then reads the directory back. Points never run concurrently:
// each uses the threads it measures, and a second run on the same cores
// would slow it by an amount that depends on the other point.
// @throws dg::Error for a scene without truth or scan, or a run that fails.
RuntimeResult RunRuntimeSweep(const RuntimeOptions& options);

// The report from a directory already on disk (after the jobs of --emit-jobs
// ran elsewhere): every runs/*/point.yaml, with its run.h5 when there is one.
// @throws dg::Error when no point is found.
RuntimeResult ReadRuntimeLogs(const std::string& dir, double cycles);

// Whether dir holds a sweep (runs/*/point.yaml): what `dynaguide report DIR` asks.
bool IsRuntimeSweepDir(const std::string& dir);

// Video seconds per wall second over a run's simulated frames, from the sink
// stage's end times in /timings: (last - first) / fps over the wall time
// between the two frames leaving the sink. The whole run's factor also counts
// the registration window's frames, which do not simulate and run several
// times faster, so it flatters a configuration whose simulation cannot keep up.
// @returns 0 when fewer than two simulated frames reached the sink.
double SimulatingRealtimeFactor(const std::vector<pipeline::StageTiming>& timings, int sink_stage,
                                std::int64_t first_frame, std::int64_t last_frame, double fps);

// Errors closer than this are the same error to a user: the report prints
// micrometres, and the sweep's steps and thread counts move the default
// phantom's errors by 0.1 um (float round-off), not by a clinical amount.
inline constexpr double kSameErrorMm = 1e-3;

// A point as the Pareto front sees it: smaller error and larger real-time factor are better.
struct CostAccuracy {
  double realtime_factor = 0;
  double error_mm = 0;
};
// For each point, whether no other point dominates it: is at least as fast,
// no less accurate beyond error_tolerance_mm, and faster or more accurate
// beyond it. Equal points are all on the front.
std::vector<bool> ParetoFront(const std::vector<CostAccuracy>& points, double error_tolerance_mm = 0);

// The point a user should pick for real time on `threads` threads: the most
// accurate (StudyInternalRmsMm) whose simulating real-time factor is at least 1,
// where errors within kSameErrorMm of the best count as equal and the
// fastest of them wins. None when no point on that many threads keeps up.
std::optional<size_t> RecommendForRealTime(const std::vector<PointResult>& points, int threads = 2);

}  // namespace dg::tools
