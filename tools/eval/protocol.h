#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tools/eval/run_errors.h"
#include "tools/phantom/beat_options.h"

namespace dg::tools {

// `dynaguide eval protocol`: the paper's validation (section 2.8, Tables 1
// and 2, Fig. 2) on phantoms with ground truth. Each scene is run once per
// constraint mode (surface, volume, combined) and policy (offline, realtime),
// registered from its own video, with the scene's overlays; the errors over
// `cycles` cardiac cycles from the simulation's start, of the simulated state
// and of the overlay as shown, are read back from the run logs.
struct ProtocolOptions {
  std::string scene;                  // empty: the default phantom, one scene per seed
  std::vector<std::uint64_t> seeds{1};
  phantom::BeatOptions beat;          // the seeds' phantoms' beat (unset fields: the preset's)
  // "offline" and/or "realtime" (pipeline::ParsePolicy): each mode runs once per policy.
  std::vector<std::string> policies{"offline", "realtime"};
  // runs/<scene>/<mode>/run.h5 (offline), runs/<scene>/<mode>-realtime/run.h5, report.md, CSV, PNG
  std::string out_dir = "out/eval";
  int threads = 0;                    // 0: all cores
  double cycles = 3;                  // the evaluation window
  std::string emit_jobs;              // write one `dynaguide run` line per run here instead of running
  // What each job line calls: the dynaguide command gives its own absolute path
  // (JobProgramPath), so the jobs need no PATH.
  std::string program = "dynaguide";
  // Give the runs the truth's registration instead of registering from the
  // video: the modes' errors without the registration's (an error budget).
  bool truth_registration = false;
  // Drive the simulations with the registration's constant phase shift
  // instead of the live phase (registration.live_phase: false): the baseline
  // the live phase is measured against.
  bool constant_phase = false;
  bool progress = true;
};

// The modes a protocol runs, in its tables' order.
const std::vector<sim::SimulationMode>& ProtocolModes();

// One mode under one policy, pooled over the scenes.
struct ProtocolEntry {
  std::string policy;  // the runs' (RunErrors::policy)
  sim::SimulationMode mode = sim::SimulationMode::kCombined;
  // Whether any run log is of this policy and mode: a directory may hold one
  // run, and an entry without runs has no figures (not zeros).
  bool ran = false;
  ErrorFigures figures;
  double realtime_factor = 0;  // the runs' median
};

struct ProtocolResult {
  std::vector<std::string> scenes;      // names, in run order
  std::vector<RunErrors> runs;          // every run read back
  // For each mode in ProtocolModes() order, an entry per policy any run log
  // is of ("offline" before "realtime"): a policy no log is of has none.
  std::vector<ProtocolEntry> entries;
  int window_frames = 0;                // frames of each run's window
  double window_cycles = 0;             // the cycles they span (short of `cycles` when a video is)

  // The entry of a policy and mode; null when no run log is of the policy.
  const ProtocolEntry* Find(const std::string& policy, sim::SimulationMode mode) const;
};

// Runs (or, with emit_jobs, lists) every scene in every mode and policy, then
// reads the logs back. @throws dg::Error for a policy other than offline and
// realtime, a scene without truth or preoperative data, or a run that fails.
ProtocolResult RunProtocol(const ProtocolOptions& options);

// The tables from run logs already on disk: every run.h5 under `dir`
// (`dynaguide report DIR`, and after jobs run elsewhere).
// @throws dg::Error when no run log with errors is found.
ProtocolResult ReadProtocolLogs(const std::string& dir, double cycles);

// Writes report.md (Table 1 per mode and policy, the state's beside the
// paper's and the overlay as shown; Table 2 beside the paper's; registration
// residuals beside its 0.47 mm), table1.csv, table2.csv, fig2_surface.png and
// fig2_internal.png (error against time per mode, offline when it ran) into out_dir. An
// entry without runs says "not run" in report.md and has no row in the CSV
// files; Table 2 (the volume mode's, offline) likewise.
// @returns the report's text. @throws dg::Error when a file cannot be written.
std::string WriteProtocolReport(const ProtocolResult& result, const std::string& out_dir);

// The JSON users script against: for each mode and policy that ran, its
// policy, surface_avg_mm, surface_max_mm, surface_rms_mm, internal_avg_mm,
// internal_max_mm, internal_rms_mm, the same as shown (shown_*), the
// fraction of frames with both layers, realtime_factor (the runs' median).
void WriteProtocolJson(const ProtocolResult& result, const std::string& path);

}  // namespace dg::tools
