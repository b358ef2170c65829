#include "tools/eval/stability_study.h"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <tuple>

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include "io/h5_file.h"
#include "sim/error.h"
#include "sim/log.h"
#include "sim/progress.h"
#include "tools/job_program.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;

// HDF5 (as Debian builds it) is not thread-safe: every log read or write in
// the study holds this.
std::mutex& LogMutex() {
  static std::mutex mutex;
  return mutex;
}

// The solver logs the guard's decision at every construction (info for a
// substep, warning for an unchecked step): thousands of lines over a grid,
// each already in its cell's log. Quiet while the study runs.
class QuietSimLog {
 public:
  QuietSimLog() : level_(Logger("sim").level()) { Logger("sim").set_level(spdlog::level::err); }
  ~QuietSimLog() { Logger("sim").set_level(level_); }

 private:
  spdlog::level::level_enum level_;
};

}  // namespace

std::vector<CellSpec> StabilityGrid::Cells() const {
  std::vector<CellSpec> cells;
  for (const std::string& motion : motions) {
    for (Guard guard : guards) {
      for (double E : youngs_modulus_pa) {
        for (double nu : poissons_ratio) {
          for (double dt : dt_s) cells.push_back({E, nu, dt, motion, guard});
        }
      }
    }
  }
  return cells;
}

StabilityGrid DefaultStabilityGrid(bool quick) {
  const std::vector<Guard> guards = {Guard::kRefuse, Guard::kSubstep, Guard::kOff};
  if (quick) return {{3e3, 1e5, 1e6}, {0.45, 0.499}, {1e-4, 5e-4}, {"default", "crush"}, guards};
  return {{3e3, 1e4, 3e4, 1e5, 3e5, 1e6}, {0.3, 0.45, 0.49, 0.499}, {5e-5, 1e-4, 2e-4, 3e-4, 5e-4},
          StudyMotions(), guards};
}

std::string BisectionCase::Name() const {
  // A cell's name without its dt and guard parts.
  const std::string cell = CellSpec{youngs_modulus_pa, poissons_ratio, 1e-3, motion, Guard::kOff}.Name();
  return cell.substr(0, cell.find("_dt")) + "_" + motion;
}

BisectionCase BisectionCase::Parse(const std::string& name) {
  const size_t motion_begin = name.rfind('_');
  if (motion_begin == std::string::npos) {
    throw Error("bisection name '" + name + "' is not E<modulus>_nu<ratio>_<motion>", "--bisect",
                "copy a name from --emit-jobs' lines, e.g. E3k_nu0.45_default");
  }
  // Parsed as the cell it names, with any dt and guard.
  const CellSpec cell =
      CellSpec::Parse(name.substr(0, motion_begin) + "_dt1ms_" + name.substr(motion_begin + 1) + "_off");
  return {cell.youngs_modulus_pa, cell.poissons_ratio, cell.motion};
}

std::vector<BisectionCase> DefaultBisectionCases(bool quick) {
  if (quick) return {{3e3, 0.45, "default"}, {1e5, 0.49, "default"}};
  return {{3e3, 0.45, "default"}, {1e4, 0.3, "default"}, {1e5, 0.49, "default"}, {1e6, 0.499, "default"}};
}

BisectionResult BisectStabilityLimit(const StudyMesh& mesh, const BisectionCase& bisection_case, double tolerance) {
  BisectionResult result;
  result.bisection_case = bisection_case;
  const sim::StabilityReport stability =
      EstimateCellStability(mesh, bisection_case.youngs_modulus_pa, bisection_case.poissons_ratio);
  result.dt_critical_s = stability.dt_critical_s;
  result.dt_element_bound_s = stability.dt_element_bound_s;
  result.trial_steps = kTrialSteps;
  CellSpec spec{bisection_case.youngs_modulus_pa, bisection_case.poissons_ratio, 0, bisection_case.motion,
                Guard::kOff};
  const auto stable = [&](double dt_s) {
    spec.dt_s = dt_s;
    const bool ok = RunsStably(mesh, spec, kTrialSteps);
    result.trial_dt_s.push_back(dt_s);
    result.trial_stable.push_back(ok);
    return ok;
  };
  const auto not_found = [&](const char* which) {
    return Error(std::string("no ") + which + " time step found", "bisection " + bisection_case.Name(),
                 "check the material and the motion with a single cell (--cell)");
  };
  // The bracket: the per-element bound should be stable (it is meant to be
  // conservative; when it is not, the trials show it), 1.25 dt_cr unstable.
  double lo = stability.dt_element_bound_s;
  for (int halvings = 0; !stable(lo); ++halvings) {
    if (halvings == 4) throw not_found("stable");
    lo /= 2;
  }
  double hi = 1.25 * stability.dt_critical_s;
  for (int doublings = 0; stable(hi); ++doublings) {
    if (doublings == 4) throw not_found("unstable");
    lo = hi;
    hi *= 2;
  }
  while (hi - lo > tolerance * lo) {
    const double mid = 0.5 * (lo + hi);
    (stable(mid) ? lo : hi) = mid;
  }
  result.dt_stable_s = lo;
  result.dt_unstable_s = hi;
  return result;
}

void WriteBisectionLog(const BisectionResult& r, const std::string& path) {
  const std::string part = path + ".part";
  fs::create_directories(fs::path(path).parent_path());
  {
    io::H5Writer log(part);
    const BisectionCase& c = r.bisection_case;
    log.WriteAttribute("/", "case", c.Name());
    log.WriteAttribute("/", "youngs_modulus_pa", c.youngs_modulus_pa);
    log.WriteAttribute("/", "poissons_ratio", c.poissons_ratio);
    log.WriteAttribute("/", "motion", c.motion);
    log.WriteAttribute("/", "dt_critical_s", r.dt_critical_s);
    log.WriteAttribute("/", "dt_element_bound_s", r.dt_element_bound_s);
    log.WriteAttribute("/", "trial_steps", static_cast<std::int64_t>(r.trial_steps));
    log.WriteAttribute("/", "dt_stable_s", r.dt_stable_s);
    log.WriteAttribute("/", "dt_unstable_s", r.dt_unstable_s);
    const size_t n = r.trial_dt_s.size();
    const std::vector<std::int32_t> stable(r.trial_stable.begin(), r.trial_stable.end());
    log.Write("/trials/dt_s", r.trial_dt_s.data(), {n});
    log.Write("/trials/stable", stable.data(), {n});
  }
  std::error_code error;
  fs::rename(part, path, error);
  if (error) throw Error("cannot rename the bisection log: " + error.message(), part, "check the directory is writable");
}

BisectionResult ReadBisectionLog(const std::string& path) {
  const io::H5Reader log(path);
  BisectionResult r;
  r.bisection_case = {log.ReadAttribute<double>("/", "youngs_modulus_pa"),
                      log.ReadAttribute<double>("/", "poissons_ratio"), log.ReadAttribute<std::string>("/", "motion")};
  r.dt_critical_s = log.ReadAttribute<double>("/", "dt_critical_s");
  r.dt_element_bound_s = log.ReadAttribute<double>("/", "dt_element_bound_s");
  r.trial_steps = log.ReadAttribute<std::int64_t>("/", "trial_steps");
  r.dt_stable_s = log.ReadAttribute<double>("/", "dt_stable_s");
  r.dt_unstable_s = log.ReadAttribute<double>("/", "dt_unstable_s");
  r.trial_dt_s = log.Read<double>("/trials/dt_s");
  for (std::int32_t s : log.Read<std::int32_t>("/trials/stable")) r.trial_stable.push_back(s);
  return r;
}

std::string CellLogPath(const std::string& out_dir, const CellSpec& spec) {
  return out_dir + "/cells/" + spec.Name() + ".h5";
}

std::string BisectionLogPath(const std::string& out_dir, const BisectionCase& bisection_case) {
  return out_dir + "/bisection/" + bisection_case.Name() + ".h5";
}

namespace {

std::string JobPrefix(const StabilityOptions& options) {
  return ShellWord(options.program) + " eval stability --out " + ShellWord(options.out_dir) + " --tets " +
         std::to_string(options.tets) +
         (options.threads > 0 ? " --threads " + std::to_string(options.threads) : "") + " --quiet";
}

// Grid order: motions as StudyMotions(), then guard, E, nu, dt.
bool GridOrder(const CellResult& a, const CellResult& b) {
  const auto key = [](const CellSpec& s) {
    const auto motion = std::find(StudyMotions().begin(), StudyMotions().end(), s.motion) - StudyMotions().begin();
    return std::tuple(motion, static_cast<int>(s.guard), s.youngs_modulus_pa, s.poissons_ratio, s.dt_s);
  };
  return key(a.spec) < key(b.spec);
}

}  // namespace

std::string CellJobCommand(const StabilityOptions& options, const CellSpec& spec) {
  return JobPrefix(options) + " --cell " + spec.Name();
}

std::string BisectionJobCommand(const StabilityOptions& options, const BisectionCase& bisection_case) {
  return JobPrefix(options) + " --bisect " + bisection_case.Name();
}

StabilityResult RunStabilityStudy(const StabilityOptions& options) {
  const std::vector<CellSpec> cells = DefaultStabilityGrid(options.quick).Cells();
  const std::vector<BisectionCase> cases = DefaultBisectionCases(options.quick);
  if (!options.emit_jobs.empty()) {
    std::ofstream jobs(options.emit_jobs);
    // Bisections first: each is a chain of trials, the longest jobs.
    for (const BisectionCase& c : cases) jobs << BisectionJobCommand(options, c) << "\n";
    for (const CellSpec& cell : cells) jobs << CellJobCommand(options, cell) << "\n";
    if (!jobs) throw Error("cannot write the job list", options.emit_jobs, "check the directory exists");
    return {};
  }
  fs::create_directories(options.out_dir);
  const StudyMesh mesh = MakeStudyMesh(options.tets);
  if (options.progress) {
    std::fprintf(stderr, "eval stability: %zu cells and %zu bisections on %d nodes, %d tets\n", cells.size(),
                 cases.size(), mesh.mesh.num_nodes(), mesh.mesh.num_tets());
  }
  const QuietSimLog quiet;
  const int threads = options.threads > 0 ? options.threads : tbb::info::default_concurrency();
  const tbb::global_control control(tbb::global_control::max_allowed_parallelism, threads);
  Progress progress("eval stability", static_cast<double>(cases.size() + cells.size()), options.progress);
  std::mutex progress_mutex;
  int done = 0;
  const auto finished = [&](const std::string& what) {
    const std::lock_guard lock(progress_mutex);
    progress.Update(++done, what);
  };
  // One item per bisection (first: the longest) or cell, handed out one at a time.
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, cases.size() + cells.size(), 1),
      [&](const tbb::blocked_range<size_t>& items) {
        for (size_t i = items.begin(); i != items.end(); ++i) {
          if (i < cases.size()) {
            const BisectionResult r = BisectStabilityLimit(mesh, cases[i]);
            {
              const std::lock_guard lock(LogMutex());
              WriteBisectionLog(r, BisectionLogPath(options.out_dir, cases[i]));
            }
            char ratio[64];
            std::snprintf(ratio, sizeof ratio, ": limit / dt_cr = %.3f", r.ratio_to_estimate());
            finished("bisection " + cases[i].Name() + ratio);
          } else {
            const CellSpec& spec = cells[i - cases.size()];
            const CellResult r = RunCell(mesh, spec);
            {
              const std::lock_guard lock(LogMutex());
              WriteCellLog(r, CellLogPath(options.out_dir, spec));
            }
            finished(spec.Name() + ": " + OutcomeName(r.outcome));
          }
        }
      },
      tbb::simple_partitioner());
  progress.Finish();

  // Everything reported is read back from the logs just written.
  StabilityResult result;
  for (const BisectionCase& c : cases) result.bisections.push_back(ReadBisectionLog(BisectionLogPath(options.out_dir, c)));
  for (const CellSpec& cell : cells) result.cells.push_back(ReadCellLog(CellLogPath(options.out_dir, cell)));
  return result;
}

StabilityResult ReadStabilityLogs(const std::string& dir) {
  StabilityResult result;
  for (const char* sub : {"/cells", "/bisection"}) {
    std::error_code error;
    for (fs::directory_iterator it(dir + sub, error), end; !error && it != end; it.increment(error)) {
      if (it->path().extension() != ".h5") continue;  // skips the .part of a job still writing
      if (std::string(sub) == "/cells") {
        result.cells.push_back(ReadCellLog(it->path().string()));
      } else {
        result.bisections.push_back(ReadBisectionLog(it->path().string()));
      }
    }
  }
  if (result.cells.empty()) {
    throw Error("no stability cell log found", dir + "/cells",
                "run `dynaguide eval stability --out " + dir + "`, or the jobs of its --emit-jobs, first");
  }
  std::sort(result.cells.begin(), result.cells.end(), GridOrder);
  std::sort(result.bisections.begin(), result.bisections.end(), [](const BisectionResult& a, const BisectionResult& b) {
    return std::pair(a.bisection_case.youngs_modulus_pa, a.bisection_case.poissons_ratio) <
           std::pair(b.bisection_case.youngs_modulus_pa, b.bisection_case.poissons_ratio);
  });
  return result;
}

}  // namespace dg::tools
