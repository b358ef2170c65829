#include "tools/eval/stability_cell.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "io/gmsh_mesher.h"
#include "io/h5_file.h"
#include "sim/error.h"
#include "sim/stability.h"
#include "sim/tled_model.h"
#include "sim/tled_solver.h"
#include "tools/phantom/heart_motion.h"

namespace dg::tools {
namespace {

// Samples per cycle of the plausibility checks and the log's time series.
constexpr int kSamplesPerCycle = 50;

// The motion's parameters: a phantom preset's, or the default one pressed down.
phantom::PhantomSpec MotionSpec(const std::string& motion) {
  if (motion == "default" || motion == "extreme") return phantom::PresetSpec(motion);
  phantom::PhantomSpec spec = phantom::PresetSpec("default");
  if (motion == "compression" || motion == "crush") {
    spec.radial_contraction = 0;
    spec.twist_rad = 0;
    spec.sway_m.setZero();
    // Deliberately outside PhantomSpec::Validate's [0, 0.4) for "crush": the
    // map z' = z (1 - l a z/H) folds over near the top once 2 l a > 1.
    spec.longitudinal_shortening = motion == "compression" ? 0.35 : 0.75;
    return spec;
  }
  throw Error("unknown motion '" + motion + "'", "stability cell", "use default, extreme, compression or crush");
}

// The cycle as it runs: the prescribed nodes' targets at any time, from the
// motion's map of the reference positions (nominal beat, repeating).
class SurfaceDrive {
 public:
  SurfaceDrive(const StudyMesh& mesh, const std::string& motion)
      : spec_(MotionSpec(motion)), motion_(spec_, 0.0), mesh_(mesh) {}

  double period_s() const { return spec_.period_s(); }

  // The map's displacement of reference point X at time t.
  Eigen::Vector3d Displacement(const Eigen::Vector3d& X, double t_s) const {
    const double phase = std::fmod(t_s / period_s(), 1.0);
    return motion_.Deform(X, phantom::HeartMotion::NominalState(phase)) - X;
  }

  // Targets (3 per prescribed node, in StudyMesh order) at time t; returns the largest.
  double Targets(double t_s, std::vector<double>* targets_m) const {
    double largest = 0;
    for (size_t k = 0; k < mesh_.prescribed_nodes.size(); ++k) {
      const Eigen::Vector3d u = Displacement(mesh_.mesh.X_m.col(mesh_.prescribed_nodes[k]), t_s);
      for (int i = 0; i < 3; ++i) (*targets_m)[3 * k + i] = u[i];
      largest = std::max(largest, u.norm());
    }
    return largest;
  }

 private:
  phantom::PhantomSpec spec_;
  phantom::HeartMotion motion_;
  const StudyMesh& mesh_;
};

sim::TimeStepPolicy Policy(Guard guard) {
  switch (guard) {
    case Guard::kRefuse:
      return sim::TimeStepPolicy::kRefuse;
    case Guard::kSubstep:
      return sim::TimeStepPolicy::kSubstep;
    case Guard::kOff:
      return sim::TimeStepPolicy::kUnchecked;
  }
  return sim::TimeStepPolicy::kRefuse;
}

// The solver's two detectors throw dg::Error; these are the problems they name
// (sim/tled_solver.cc). Anything else is not an outcome and propagates.
bool IsInversion(const Error& error) { return error.problem().rfind("inverted element", 0) == 0; }
bool IsBlowUp(const Error& error) {
  return error.problem().rfind("numerical blow-up", 0) == 0 || error.problem().rfind("non-finite", 0) == 0;
}

std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", value);
  return text;
}

// A number with an optional k or M suffix, as Name() writes Young's modulus.
double ParseScaled(const std::string& text, const std::string& part) {
  size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  const std::string suffix = text.substr(used);
  if (used == 0 || !(suffix.empty() || suffix == "k" || suffix == "M")) {
    throw Error("cannot read '" + text + "' as a number", "cell name, " + part,
                "write it as in 3k, 0.45 or 0.2ms (see --emit-jobs' lines)");
  }
  return value * (suffix == "k" ? 1e3 : suffix == "M" ? 1e6 : 1.0);
}

sim::Material CellMaterial(const CellSpec& spec) {
  const sim::Material material{spec.youngs_modulus_pa, spec.poissons_ratio, 1.0e3};
  if (const std::string wrong = material.Validate(); !wrong.empty()) {
    throw Error("invalid material: " + wrong, "cell " + spec.Name(), "choose E > 0 and 0 <= nu < 0.5");
  }
  return material;
}

sim::BoundaryConditions Conditions(const StudyMesh& study) {
  sim::BoundaryConditions conditions;
  conditions.fixed_dofs = study.fixed_dofs;
  for (int node : study.prescribed_nodes) {
    for (int i = 0; i < 3; ++i) conditions.prescribed_dofs.push_back(3 * node + i);
  }
  return conditions;
}

// The assembled and per-element limits of the cell's material on the mesh.
sim::StabilityReport CellStability(const StudyMesh& study, const sim::Material& material) {
  const sim::BoundaryConditions conditions = Conditions(study);
  std::vector<int> constrained = conditions.fixed_dofs;
  constrained.insert(constrained.end(), conditions.prescribed_dofs.begin(), conditions.prescribed_dofs.end());
  return sim::EstimateStability(study.mesh, material, constrained);
}

// The guard acts here: with kRefuse, a dt above its limit throws.
std::unique_ptr<sim::TledSolver<float>> MakeSolver(const StudyMesh& study, const sim::Material& material,
                                                   const sim::StabilityReport& stability, double dt_s,
                                                   sim::TimeStepPolicy policy) {
  sim::SolverOptions options;
  options.dt_s = dt_s;
  options.time_step_policy = policy;
  options.threads = 1;  // the study runs its cells side by side
  auto model = std::make_shared<const sim::TledModel<float>>(study.mesh, material);
  return std::make_unique<sim::TledSolver<float>>(model, Conditions(study), options, &stability);
}

// Over the free nodes: the largest displacement and the largest distance
// from the motion's map (both m). Non-finite values come out infinite.
std::pair<double, double> FreeNodeExtent(const StudyMesh& study, const std::vector<char>& is_free,
                                         const SurfaceDrive& drive, const Eigen::Matrix3Xd& u, double t_s) {
  double free_max = 0, deviation = 0;
  for (int a = 0; a < study.mesh.num_nodes(); ++a) {
    if (!is_free[a]) continue;
    const double norm = u.col(a).norm();
    const double off = (u.col(a) - drive.Displacement(study.mesh.X_m.col(a), t_s)).norm();
    free_max = std::isfinite(norm) ? std::max(free_max, norm) : INFINITY;
    deviation = std::isfinite(off) ? std::max(deviation, off) : INFINITY;
  }
  return {free_max, deviation};
}

std::vector<char> FreeNodes(const StudyMesh& study) {
  std::vector<char> is_free(study.mesh.num_nodes(), 1);
  for (int dof : study.fixed_dofs) is_free[dof / 3] = 0;
  for (int node : study.prescribed_nodes) is_free[node] = 0;
  return is_free;
}

// Steps the solver through `steps` steps of the drive from rest, sampling the
// state into `result` as it goes (so a run a detector stops keeps its trace
// up to there). Errors from the solver propagate.
void Simulate(const StudyMesh& study, const SurfaceDrive& drive, long long steps, bool keep_states,
              sim::TledSolver<float>& solver, CellResult* result) {
  const std::vector<char> is_free = FreeNodes(study);
  const double dt = solver.options().dt_s;
  const long long per_cycle = std::max(1LL, std::llround(drive.period_s() / dt));
  const long long sample_every = std::max(1LL, per_cycle / kSamplesPerCycle);
  std::vector<double> targets(3 * study.prescribed_nodes.size());
  CellResult::Samples& samples = result->samples;
  double largest_prescribed_m = 0;

  const auto sample = [&](long long step) {
    const double t = step * dt;
    const Eigen::Matrix3Xd u = solver.DisplacementMatrix();
    const auto [free_max, deviation] = FreeNodeExtent(study, is_free, drive, u, t);
    samples.t_s.push_back(t);
    samples.kinetic_energy_j.push_back(solver.kinetic_energy_j());
    samples.min_jacobian.push_back(solver.min_jacobian());
    samples.max_free_displacement_mm.push_back(free_max * 1e3);
    samples.map_deviation_mm.push_back(deviation * 1e3);
    result->min_jacobian = std::min(result->min_jacobian, solver.min_jacobian());
    if (keep_states && step == steps / 2) result->u_peak_m = u;
    if (keep_states && step == steps) result->u_final_m = u;
  };

  const auto start = std::chrono::steady_clock::now();
  const auto finish = [&] {
    result->wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    result->internal_steps = solver.steps_taken();
    result->simulated_s = solver.time_s();
    result->max_prescribed_mm = largest_prescribed_m * 1e3;
  };
  try {
    sample(0);
    for (long long step = 1; step <= steps; ++step) {
      largest_prescribed_m = std::max(largest_prescribed_m, drive.Targets(step * dt, &targets));
      solver.Advance(1, targets);
      if (step % sample_every == 0 || step == steps / 2 || step == steps) sample(step);
    }
  } catch (const Error&) {
    finish();
    throw;
  }
  finish();
}

// Empty when the run's samples look like a response to the motion; otherwise
// why not. A blow-up the solver's detectors miss (a slow one, or one of a
// constrained region) shows here as free nodes far off the motion's smooth map.
std::string Implausible(const CellResult& r, bool end_of_cycle) {
  char why[200];
  const double scale = std::max(r.max_prescribed_mm, 1e-9);
  for (size_t k = 0; k < r.samples.t_s.size(); ++k) {
    const double ratio = r.samples.map_deviation_mm[k] / scale;
    if (!(ratio <= kMaxMapDeviationRatio)) {
      std::snprintf(why, sizeof why,
                    "implausible state at t = %.4g s: a free node is %.3g mm off the motion's map, %.3g x the largest "
                    "prescribed displacement (plausible: <= %.2g x)",
                    r.samples.t_s[k], r.samples.map_deviation_mm[k], ratio, kMaxMapDeviationRatio);
      return why;
    }
  }
  if (end_of_cycle && !(r.final_ratio <= kMaxFinalRatio)) {
    std::snprintf(why, sizeof why,
                  "implausible final state: the motion is back at rest but a free node is displaced %.3g x the "
                  "largest prescribed displacement (plausible: <= %.2g x)",
                  r.final_ratio, kMaxFinalRatio);
    return why;
  }
  return {};
}

}  // namespace

const std::vector<CellOutcome>& AllOutcomes() {
  static const std::vector<CellOutcome> outcomes = {CellOutcome::kStable, CellOutcome::kRefused,
                                                    CellOutcome::kSubstepped, CellOutcome::kInversion,
                                                    CellOutcome::kBlowUp};
  return outcomes;
}

std::string OutcomeName(CellOutcome outcome) {
  switch (outcome) {
    case CellOutcome::kStable:
      return "stable";
    case CellOutcome::kRefused:
      return "refused";
    case CellOutcome::kSubstepped:
      return "substepped";
    case CellOutcome::kInversion:
      return "inversion";
    case CellOutcome::kBlowUp:
      return "blow-up";
  }
  return "?";
}

CellOutcome ParseOutcome(const std::string& name) {
  for (CellOutcome outcome : AllOutcomes()) {
    if (OutcomeName(outcome) == name) return outcome;
  }
  throw Error("unknown outcome '" + name + "'", "stability cell log",
              "the log was written by another version: re-run the cell");
}

std::string GuardName(Guard guard) {
  switch (guard) {
    case Guard::kRefuse:
      return "refuse";
    case Guard::kSubstep:
      return "substep";
    case Guard::kOff:
      return "off";
  }
  return "?";
}

Guard ParseGuard(const std::string& name) {
  for (Guard guard : {Guard::kRefuse, Guard::kSubstep, Guard::kOff}) {
    if (GuardName(guard) == name) return guard;
  }
  throw Error("unknown guard '" + name + "'", "--guards or cell name", "use refuse, substep or off");
}

const std::vector<std::string>& StudyMotions() {
  static const std::vector<std::string> motions = {"default", "extreme", "compression", "crush"};
  return motions;
}

std::string CellSpec::Name() const {
  const double E = youngs_modulus_pa;
  const std::string modulus = E >= 1e6 ? Number(E / 1e6) + "M" : E >= 1e3 ? Number(E / 1e3) + "k" : Number(E);
  return "E" + modulus + "_nu" + Number(poissons_ratio) + "_dt" + Number(dt_s * 1e3) + "ms_" + motion + "_" +
         GuardName(guard);
}

CellSpec CellSpec::Parse(const std::string& name) {
  std::vector<std::string> parts;
  for (size_t begin = 0;;) {
    const size_t end = name.find('_', begin);
    parts.push_back(name.substr(begin, end - begin));
    if (end == std::string::npos) break;
    begin = end + 1;
  }
  const auto has_prefix = [](const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; };
  if (parts.size() != 5 || !has_prefix(parts[0], "E") || !has_prefix(parts[1], "nu") || !has_prefix(parts[2], "dt") ||
      parts[2].size() < 5 || parts[2].substr(parts[2].size() - 2) != "ms") {
    throw Error("cell name '" + name + "' is not E<modulus>_nu<ratio>_dt<ms>ms_<motion>_<guard>", "--cell",
                "copy a name from --emit-jobs' lines, e.g. E3k_nu0.45_dt0.2ms_default_refuse");
  }
  CellSpec spec;
  spec.youngs_modulus_pa = ParseScaled(parts[0].substr(1), "modulus");
  spec.poissons_ratio = ParseScaled(parts[1].substr(2), "Poisson's ratio");
  spec.dt_s = ParseScaled(parts[2].substr(2, parts[2].size() - 4), "time step") * 1e-3;
  spec.motion = parts[3];
  if (std::find(StudyMotions().begin(), StudyMotions().end(), spec.motion) == StudyMotions().end()) {
    throw Error("unknown motion '" + spec.motion + "'", "cell name " + name, "use default, extreme, compression or crush");
  }
  spec.guard = ParseGuard(parts[4]);
  return spec;
}

StudyMesh MakeStudyMesh(int target_tets) {
  const phantom::PhantomSpec phantom = phantom::PresetSpec("default");
  io::TruncatedEllipsoidSpec spec;
  spec.semi_axes_m = phantom.semi_axes_m;
  spec.centre_height_m = phantom.centre_height_m;
  spec.target_tets = target_tets;
  StudyMesh study;
  study.mesh = io::MeshTruncatedEllipsoid(spec);
  study.target_tets = target_tets;
  for (int node : study.mesh.node_sets.at("base")) {
    for (int i = 0; i < 3; ++i) study.fixed_dofs.push_back(3 * node + i);
  }
  for (int node : study.mesh.node_sets.at("surface")) {
    if (study.mesh.X_m(2, node) > phantom.centre_height_m) study.prescribed_nodes.push_back(node);
  }
  return study;
}

namespace {

// The ratios Implausible() checks, from the samples.
void SetRatios(CellResult* r) {
  const double scale = std::max(r->max_prescribed_mm, 1e-9);
  r->map_deviation_ratio = 0;
  for (double d : r->samples.map_deviation_mm) r->map_deviation_ratio = std::max(r->map_deviation_ratio, d / scale);
  if (r->samples.t_s.empty()) return;
  // A non-finite sample stays visible as such (max() would drop a NaN).
  for (double d : r->samples.map_deviation_mm) {
    if (!std::isfinite(d)) r->map_deviation_ratio = INFINITY;
  }
  r->final_ratio = r->samples.max_free_displacement_mm.back() / scale;
}

}  // namespace

sim::StabilityReport EstimateCellStability(const StudyMesh& study, double youngs_modulus_pa, double poissons_ratio) {
  return CellStability(study, CellMaterial({youngs_modulus_pa, poissons_ratio}));
}

CellResult RunCell(const StudyMesh& study, const CellSpec& spec) {
  CellResult result;
  result.spec = spec;
  result.nodes = study.mesh.num_nodes();
  result.tets = study.mesh.num_tets();
  const sim::Material material = CellMaterial(spec);
  const sim::StabilityReport stability = CellStability(study, material);
  result.dt_critical_s = stability.dt_critical_s;
  result.dt_element_bound_s = stability.dt_element_bound_s;
  const SurfaceDrive drive(study, spec.motion);

  std::unique_ptr<sim::TledSolver<float>> solver;
  try {
    solver = MakeSolver(study, material, stability, spec.dt_s, Policy(spec.guard));
  } catch (const Error& refusal) {
    if (spec.guard != Guard::kRefuse) throw;
    result.outcome = CellOutcome::kRefused;
    result.detector = "guard";
    result.message = refusal.what();
    result.substeps = 0;
    return result;
  }
  result.substeps = solver->substeps_per_step();
  const long long steps = std::llround(drive.period_s() / spec.dt_s);
  try {
    Simulate(study, drive, steps, /*keep_states=*/true, *solver, &result);
  } catch (const Error& error) {
    if (!IsInversion(error) && !IsBlowUp(error)) throw;
    result.outcome = IsInversion(error) ? CellOutcome::kInversion : CellOutcome::kBlowUp;
    result.detector = "solver";
    result.message = error.what();
    SetRatios(&result);
    // A step far above the limit inverts elements within a few steps, before
    // the energy detector's windows fill: such an inversion, with the free
    // nodes far off the motion, is a blow-up's symptom, and reported as one.
    const double deviation_m =
        FreeNodeExtent(study, FreeNodes(study), drive, solver->DisplacementMatrix(), solver->time_s()).second;
    const double ratio = deviation_m * 1e3 / std::max(result.max_prescribed_mm, 1e-9);
    result.map_deviation_ratio = std::isfinite(ratio) ? std::max(result.map_deviation_ratio, ratio) : INFINITY;
    if (result.outcome == CellOutcome::kInversion && !(ratio <= kMaxMapDeviationRatio)) {
      char why[160];
      std::snprintf(why, sizeof why, "blow-up: a free node is %.3g x the largest prescribed displacement off the "
                    "motion's map as an element inverts: ", ratio);
      result.outcome = CellOutcome::kBlowUp;
      result.detector = "study";
      result.message = why + result.message;
    }
    return result;
  }
  SetRatios(&result);
  if (const std::string why = Implausible(result, /*end_of_cycle=*/true); !why.empty()) {
    result.outcome = CellOutcome::kBlowUp;
    result.detector = "study";
    result.message = why;
    return result;
  }
  result.outcome = result.substeps > 1 ? CellOutcome::kSubstepped : CellOutcome::kStable;
  return result;
}

bool RunsStably(const StudyMesh& study, const CellSpec& spec, long long steps) {
  const sim::Material material = CellMaterial(spec);
  const sim::StabilityReport stability = CellStability(study, material);
  const SurfaceDrive drive(study, spec.motion);
  const auto solver = MakeSolver(study, material, stability, spec.dt_s, sim::TimeStepPolicy::kUnchecked);
  CellResult result;
  try {
    Simulate(study, drive, steps, /*keep_states=*/false, *solver, &result);
  } catch (const Error& error) {
    if (IsInversion(error) || IsBlowUp(error)) return false;
    throw;
  }
  SetRatios(&result);
  return Implausible(result, /*end_of_cycle=*/false).empty();
}

namespace {

void WriteState(io::H5Writer& log, const std::string& dataset, const Eigen::Matrix3Xd& u) {
  // Column-major 3 x N is row-major N x 3.
  if (u.size()) log.Write(dataset, u.data(), {static_cast<size_t>(u.cols()), 3});
}

Eigen::Matrix3Xd ReadState(const io::H5Reader& log, const std::string& dataset) {
  if (!log.Has(dataset)) return {};
  io::H5Shape shape;
  const std::vector<double> values = log.Read<double>(dataset, &shape);
  return Eigen::Map<const Eigen::Matrix3Xd>(values.data(), 3, static_cast<Eigen::Index>(shape.at(0)));
}

}  // namespace

void WriteCellLog(const CellResult& r, const std::string& path) {
  const std::string part = path + ".part";
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  {
    io::H5Writer log(part);
    const CellSpec& s = r.spec;
    log.WriteAttribute("/", "cell", s.Name());
    log.WriteAttribute("/", "youngs_modulus_pa", s.youngs_modulus_pa);
    log.WriteAttribute("/", "poissons_ratio", s.poissons_ratio);
    log.WriteAttribute("/", "dt_s", s.dt_s);
    log.WriteAttribute("/", "motion", s.motion);
    log.WriteAttribute("/", "guard", GuardName(s.guard));
    log.WriteAttribute("/", "outcome", OutcomeName(r.outcome));
    log.WriteAttribute("/", "detector", r.detector);
    log.WriteAttribute("/", "message", r.message);
    log.WriteAttribute("/", "nodes", r.nodes);
    log.WriteAttribute("/", "tets", r.tets);
    log.WriteAttribute("/", "precision", std::string("float"));
    log.WriteAttribute("/", "dt_critical_s", r.dt_critical_s);
    log.WriteAttribute("/", "dt_element_bound_s", r.dt_element_bound_s);
    log.WriteAttribute("/", "substeps", r.substeps);
    log.WriteAttribute("/", "internal_steps", static_cast<std::int64_t>(r.internal_steps));
    log.WriteAttribute("/", "simulated_s", r.simulated_s);
    log.WriteAttribute("/", "wall_s", r.wall_s);
    log.WriteAttribute("/", "max_prescribed_mm", r.max_prescribed_mm);
    log.WriteAttribute("/", "map_deviation_ratio", r.map_deviation_ratio);
    log.WriteAttribute("/", "final_ratio", r.final_ratio);
    log.WriteAttribute("/", "min_jacobian", r.min_jacobian);
    const CellResult::Samples& samples = r.samples;
    if (const size_t n = samples.t_s.size(); n > 0) {  // a refused cell never ran
      log.Write("/samples/t_s", samples.t_s.data(), {n});
      log.Write("/samples/kinetic_energy_J", samples.kinetic_energy_j.data(), {n});
      log.Write("/samples/min_J", samples.min_jacobian.data(), {n});
      log.Write("/samples/max_free_displacement_mm", samples.max_free_displacement_mm.data(), {n});
      log.Write("/samples/map_deviation_mm", samples.map_deviation_mm.data(), {n});
    }
    WriteState(log, "/u_peak_m", r.u_peak_m);
    WriteState(log, "/u_final_m", r.u_final_m);
  }
  std::error_code error;
  std::filesystem::rename(part, path, error);
  if (error) throw Error("cannot rename the cell log: " + error.message(), part, "check the directory is writable");
}

CellResult ReadCellLog(const std::string& path) {
  const io::H5Reader log(path);
  CellResult r;
  const auto text = [&](const char* name) { return log.ReadAttribute<std::string>("/", name); };
  const auto real = [&](const char* name) { return log.ReadAttribute<double>("/", name); };
  const auto integer = [&](const char* name) { return log.ReadAttribute<std::int64_t>("/", name); };
  r.spec.youngs_modulus_pa = real("youngs_modulus_pa");
  r.spec.poissons_ratio = real("poissons_ratio");
  r.spec.dt_s = real("dt_s");
  r.spec.motion = text("motion");
  r.spec.guard = ParseGuard(text("guard"));
  r.outcome = ParseOutcome(text("outcome"));
  r.detector = text("detector");
  r.message = text("message");
  r.nodes = static_cast<int>(integer("nodes"));
  r.tets = static_cast<int>(integer("tets"));
  r.dt_critical_s = real("dt_critical_s");
  r.dt_element_bound_s = real("dt_element_bound_s");
  r.substeps = static_cast<int>(integer("substeps"));
  r.internal_steps = integer("internal_steps");
  r.simulated_s = real("simulated_s");
  r.wall_s = real("wall_s");
  r.max_prescribed_mm = real("max_prescribed_mm");
  r.map_deviation_ratio = real("map_deviation_ratio");
  r.final_ratio = real("final_ratio");
  r.min_jacobian = real("min_jacobian");
  if (log.Has("/samples/t_s")) {
    r.samples.t_s = log.Read<double>("/samples/t_s");
    r.samples.kinetic_energy_j = log.Read<double>("/samples/kinetic_energy_J");
    r.samples.min_jacobian = log.Read<double>("/samples/min_J");
    r.samples.max_free_displacement_mm = log.Read<double>("/samples/max_free_displacement_mm");
    r.samples.map_deviation_mm = log.Read<double>("/samples/map_deviation_mm");
  }
  r.u_peak_m = ReadState(log, "/u_peak_m");
  r.u_final_m = ReadState(log, "/u_final_m");
  return r;
}

}  // namespace dg::tools
