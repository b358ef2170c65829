#pragma once

#include <string>
#include <vector>

#include "tools/eval/stability_cell.h"

namespace dg::tools {

// `dynaguide eval stability`: the explicit solver on stiff and
// extreme cases. A grid over Young's modulus x Poisson's ratio x time step x
// motion x guard, each cell simulated once on the phantom's mesh and ending
// as exactly one CellOutcome; and, for a few materials, the true stability
// limit found by bisection on dt with the guard off, against the guard's
// estimates. Every figure of the report is read back from the per-cell logs.

// The grid's axes; Cells() is their product, in this order (motion slowest,
// then guard, E, nu, dt).
struct StabilityGrid {
  std::vector<double> youngs_modulus_pa;
  std::vector<double> poissons_ratio;
  std::vector<double> dt_s;
  std::vector<std::string> motions;
  std::vector<Guard> guards;
  std::vector<CellSpec> Cells() const;
};

// Default: E 3k..1M Pa (6), nu 0.3..0.499 (4), dt 0.05..0.5 ms (5), motions
// default, extreme, compression, crush, guards refuse, substep, off: 1440 cells.
// Quick (tests, CI): E 3k, 100k, 1M; nu 0.45, 0.499; dt 0.1, 0.5 ms; motions
// default, crush; guards refuse, substep, off: 72 cells.
StabilityGrid DefaultStabilityGrid(bool quick);

// A bisection case: a material and a motion; named like a cell without dt and guard ("E3k_nu0.45_default").
struct BisectionCase {
  double youngs_modulus_pa = 3e3;
  double poissons_ratio = 0.45;
  std::string motion = "default";
  std::string Name() const;
  static BisectionCase Parse(const std::string& name);  // @throws dg::Error
};
// Default: the paper's tissue (3k, 0.45), the stiff preset's (100k, 0.49), a
// compressible soft one (10k, 0.3) and the stiffest corner (1M, 0.499), all
// under the default motion. Quick: (3k, 0.45) and (100k, 0.49).
std::vector<BisectionCase> DefaultBisectionCases(bool quick);

struct BisectionResult {
  BisectionCase bisection_case;
  double dt_critical_s = 0;       // the guard's assembled estimate
  double dt_element_bound_s = 0;  // the per-element bound
  long long trial_steps = 0;      // steps of each trial
  std::vector<double> trial_dt_s; // every trial, in order
  std::vector<int> trial_stable;  // 1 when that trial ran stably
  double dt_stable_s = 0;         // the largest stable and smallest unstable step tried
  double dt_unstable_s = 0;
  double limit_s() const { return 0.5 * (dt_stable_s + dt_unstable_s); }
  double ratio_to_estimate() const { return limit_s() / dt_critical_s; }
  double ratio_to_element_bound() const { return limit_s() / dt_element_bound_s; }
};

// The bracket [stable, unstable] narrowed to a relative width below `tolerance`,
// starting from [per-element bound, 1.25 dt_cr]. Each trial runs the guard
// off for kTrialSteps steps from the start of the motion: a step (1 + e) times
// the limit grows its mode by about 1 + 2 sqrt(2 e) per step, 1.14 at
// e = 0.25% (half the tolerance), so from float round-off to a detection in
// about 150 steps; and the deformation stays near the reference state the
// guard estimates dt_cr at (for a stiff material, 3000 steps are a few
// hundredths of the cycle).
// @throws dg::Error when no stable or no unstable step is found in [bound / 16, 16 dt_cr].
BisectionResult BisectStabilityLimit(const StudyMesh& mesh, const BisectionCase& bisection_case,
                                     double tolerance = 0.005);

// Bisection logs, as the cells' (HDF5, written then renamed).
void WriteBisectionLog(const BisectionResult& result, const std::string& path);
BisectionResult ReadBisectionLog(const std::string& path);

inline constexpr long long kTrialSteps = 3000;
inline constexpr int kDefaultStudyTets = 1000;

struct StabilityOptions {
  std::string out_dir = "out/stability";  // cells/*.h5, bisection/*.h5, stability.md, .csv, heat map
  bool quick = false;                     // DefaultStabilityGrid(true), DefaultBisectionCases(true)
  int threads = 0;                        // cells run in parallel up to this (0: all cores)
  int tets = kDefaultStudyTets;           // the mesh's target element count
  std::string emit_jobs;                  // write one command per cell and bisection here instead of running
  // What each job line calls: the dynaguide command gives its own absolute path
  // (JobProgramPath), so the jobs need no PATH.
  std::string program = "dynaguide";
  bool progress = true;                   // progress on stderr (Progress: each tenth when not a terminal)
};

struct StabilityResult {
  std::vector<CellResult> cells;
  std::vector<BisectionResult> bisections;
};

// Where a cell's or a bisection's log goes under out_dir.
std::string CellLogPath(const std::string& out_dir, const CellSpec& spec);
std::string BisectionLogPath(const std::string& out_dir, const BisectionCase& bisection_case);

// The command line that runs one cell or bisection as a job (--emit-jobs).
std::string CellJobCommand(const StabilityOptions& options, const CellSpec& spec);
std::string BisectionJobCommand(const StabilityOptions& options, const BisectionCase& bisection_case);

// Runs (or, with emit_jobs, lists) every cell and bisection, each writing its
// log, then reads the logs back. Cells run concurrently on a tbb::parallel_for
// (each is a few hundred to a few thousand elements: too small for the
// solver's own loops to use two cores well, so whole cells go to threads).
// @throws dg::Error when the mesh cannot be made or a log cannot be written.
StabilityResult RunStabilityStudy(const StabilityOptions& options);

// Every cell and bisection log under dir (`dynaguide report DIR`, and after
// emitted jobs ran elsewhere), cells in grid order.
// @throws dg::Error when no cell log is found.
StabilityResult ReadStabilityLogs(const std::string& dir);

}  // namespace dg::tools
