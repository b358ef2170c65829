#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "sim/stability.h"
#include "sim/tet_mesh.h"

namespace dg::tools {

// One cell of `dynaguide eval stability`: the phantom's mesh with a
// material, a time step, a motion of its tracked surface and a time-step
// guard, simulated once over one cardiac cycle and classified.

// How a cell ends: exactly one of these.
enum class CellOutcome {
  kStable,      // ran to the end with one step per dt, final state finite and plausible
  kRefused,     // the guard (kRefuse) refused dt above its safety fraction of dt_cr
  kSubstepped,  // the guard (kSubstep) split dt into substeps, then as kStable
  kInversion,   // an element reached J <= 0 (the solver's detector)
  kBlowUp,      // energy growth or a non-finite value (the solver), or an implausible state (the study)
};
const std::vector<CellOutcome>& AllOutcomes();
std::string OutcomeName(CellOutcome outcome);  // stable, refused, substepped, inversion, blow-up
// @throws dg::Error for an unknown name.
CellOutcome ParseOutcome(const std::string& name);

// The guard's policy (sim::TimeStepPolicy) under the names the study uses.
enum class Guard { kRefuse, kSubstep, kOff };
std::string GuardName(Guard guard);  // refuse, substep, off
Guard ParseGuard(const std::string& name);  // @throws dg::Error for an unknown name

// Motions of the tracked (upper) surface, each one nominal cardiac cycle:
// "default" and "extreme" are the phantom presets' heartbeats (the "stiff"
// preset beats as "default": it differs only in its material, a grid point);
// "compression" presses the top down by 35% of the height (uniaxial, no
// twist or sway); "crush" by 75%, where the map folds over near the top
// (dz'/dz < 0): it crushes the cap, and inverts elements of all but the
// softest compressible materials.
const std::vector<std::string>& StudyMotions();

struct CellSpec {
  double youngs_modulus_pa = 3e3;
  double poissons_ratio = 0.45;
  double dt_s = 2e-4;
  std::string motion = "default";
  Guard guard = Guard::kRefuse;

  // A file and command-line name that round-trips, e.g. "E3k_nu0.45_dt0.2ms_default_refuse".
  std::string Name() const;
  // @throws dg::Error naming the part that does not parse.
  static CellSpec Parse(const std::string& name);
};

// The study's mesh: the phantom's tissue (a cut ellipsoid on its mount,
// tools/phantom) meshed by Gmsh, with its boundary conditions: the flat base
// fixed, the curved surface above the ellipsoid's centre (what the endoscope
// sees and tracks) prescribed to follow the motion, the rest free.
struct StudyMesh {
  sim::TetMesh mesh;
  std::vector<int> fixed_dofs;
  std::vector<int> prescribed_nodes;
  int target_tets = 0;
};
// Deterministic (Gmsh is, bit for bit), so a cell run as a separate job meshes
// the same. @throws dg::Error from the mesher.
StudyMesh MakeStudyMesh(int target_tets);

struct CellResult {
  CellSpec spec;
  CellOutcome outcome = CellOutcome::kStable;
  std::string detector;  // who decided a non-stable outcome: "guard", "solver", "study"
  std::string message;   // the guard's or solver's error, or why the state is implausible
  int nodes = 0, tets = 0;
  double dt_critical_s = 0;       // assembled estimate (Lanczos)
  double dt_element_bound_s = 0;  // min_e L_e / c
  int substeps = 1;               // per dt
  long long internal_steps = 0;   // steps taken (substeps counted)
  double simulated_s = 0;         // up to the end or the detection
  double wall_s = 0;              // stepping only
  // Plausibility, from the samples: the largest displacement of a free node
  // away from the motion's smooth map, and the free nodes' largest
  // displacement at the end of the cycle (where the map is the identity),
  // both over the largest prescribed displacement.
  double max_prescribed_mm = 0;
  double map_deviation_ratio = 0;
  double final_ratio = 0;
  double min_jacobian = 1;  // over the samples
  // The run's time series, kSamplesPerCycle samples a cycle (the log's /samples).
  struct Samples {
    std::vector<double> t_s, kinetic_energy_j, min_jacobian, max_free_displacement_mm, map_deviation_mm;
  } samples;
  // Displacements (3 x N, m) at peak contraction (half the cycle) and at the
  // end; empty when the run did not reach them.
  Eigen::Matrix3Xd u_peak_m, u_final_m;
};

// The thresholds of "plausible" (see RunCell). A free node may lag or bulge
// away from the motion's smooth map (a near-incompressible body squeezed by
// the prescribed surface bulges by about 1.6 x the largest prescribed
// displacement on the default grid), but not by ten times it: the blow-ups
// measured are 1e2 to 1e14 times. At the cycle's end, where the map is the
// identity, stable cells are back to within 0.2% of the largest prescribed
// displacement; 5% is allowed.
inline constexpr double kMaxMapDeviationRatio = 10.0;
inline constexpr double kMaxFinalRatio = 0.05;

// The guard's two limits for a material on the study's mesh and conditions
// (sim::EstimateStability). @throws dg::Error for an invalid material.
sim::StabilityReport EstimateCellStability(const StudyMesh& mesh, double youngs_modulus_pa, double poissons_ratio);

// Simulates one cell (float, the pipeline's precision) on the mesh and
// classifies it. Runs on the calling thread (and TBB's, for the solver's loops).
// @throws dg::Error only for a problem that is none of the outcomes (a bad spec).
CellResult RunCell(const StudyMesh& mesh, const CellSpec& spec);

// One trial of a bisection: the cell with the guard off, for `steps` steps of
// dt_s from the start of the motion. True when the solver's detectors and
// the plausibility checks pass.
bool RunsStably(const StudyMesh& mesh, const CellSpec& spec, long long steps);

// The per-cell log: HDF5 at path (written to path.part, then renamed, so a
// reader never sees half a log), and reading it back.
// @throws dg::Error when the file cannot be written or read.
void WriteCellLog(const CellResult& result, const std::string& path);
CellResult ReadCellLog(const std::string& path);

}  // namespace dg::tools
