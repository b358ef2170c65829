#include "tools/eval/runtime_sweep.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <tuple>

#include "io/gmsh_reader.h"
#include "io/h5_file.h"
#include "io/scene.h"
#include "pipeline/run_scene.h"
#include "sim/error.h"
#include "sim/stability.h"
#include "sim/tled_solver.h"
#include "tools/bench/bench_json.h"
#include "tools/eval/runtime_mesh.h"
#include "tools/job_program.h"
#include "tools/report/saved_run.h"
#include "tools/phantom/phantom_cache.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;

constexpr const char* kPointFile = "point.yaml";

// The scene as one sweep point, beside the phantom's (its relative paths
// still resolve): its time step, and its mesh and the motion recorded for it.
std::string WritePointScene(const io::Scene& scene, const SweepPoint& point, const MeshVariant* variant) {
  YAML::Node root = YAML::Load(scene.text);
  root["simulation"]["dt_s"] = point.dt_s;
  root["simulation"]["precision"] = sim::ToString(point.precision);
  if (variant) {
    root["mesh"]["file"] = variant->mesh_file;
    root["preoperative"]["motion"] = variant->scan_file;
  }
  const std::string path = (fs::path(scene.path).parent_path() / ("eval-runtime-" + point.Name() + ".yaml")).string();
  std::ofstream out(path);
  out << "# " << scene.path << " as the point " << point.Name() << " of `dynaguide eval runtime`\n"
      << YAML::Dump(root) << "\n";
  if (!out) throw Error("cannot write the point's scene", path, "make the scene's directory writable");
  return path;
}

// The point's scene and mesh, and the guard's verdict on its time step.
PointPlan PlanPoint(const io::Scene& phantom, const SweepPoint& point) {
  PointPlan plan;
  plan.point = point;
  std::optional<MeshVariant> variant;
  if (point.target_tets > 0) variant = PhantomMeshVariant(phantom, point.target_tets);
  plan.scene = WritePointScene(phantom, point, variant ? &*variant : nullptr);
  const io::Scene scene = io::ReadScene(plan.scene);
  const sim::TetMesh mesh = io::ReadGmsh(scene.mesh.file, scene.mesh.metres_per_unit);
  plan.tets = mesh.num_tets();
  plan.nodes = mesh.num_nodes();
  // As the run's solver estimates it: the mount's nodes held, nothing else.
  std::vector<int> fixed_dofs;
  for (int node : mesh.node_sets.at(scene.mesh.fixed_set)) {
    for (int axis = 0; axis < 3; ++axis) fixed_dofs.push_back(3 * node + axis);
  }
  plan.dt_critical_s = sim::EstimateStability(mesh, scene.material, fixed_dofs).dt_critical_s;
  plan.safety = sim::DefaultStabilitySafety(scene.material.poissons_ratio);
  plan.refused = point.dt_s > plan.safety * plan.dt_critical_s;
  return plan;
}

double LoadAverage() {
  double load = 0;
  std::ifstream("/proc/loadavg") >> load;
  return load;
}

void WritePointFile(const std::string& dir, const std::string& scene_name, const PointPlan& plan, double load_average,
                    const std::string& error) {
  YAML::Emitter yaml;
  yaml << YAML::BeginMap;
  yaml << YAML::Key << "name" << YAML::Value << plan.point.Name();
  yaml << YAML::Key << "scene_name" << YAML::Value << scene_name;
  yaml << YAML::Key << "scene" << YAML::Value << plan.scene;
  yaml << YAML::Key << "target_tets" << YAML::Value << plan.point.target_tets;
  yaml << YAML::Key << "tets" << YAML::Value << plan.tets;
  yaml << YAML::Key << "nodes" << YAML::Value << plan.nodes;
  yaml << YAML::Key << "dt_s" << YAML::Value << plan.point.dt_s;
  yaml << YAML::Key << "target_features" << YAML::Value << plan.point.target_features;
  yaml << YAML::Key << "threads" << YAML::Value << plan.point.threads;
  yaml << YAML::Key << "precision" << YAML::Value << sim::ToString(plan.point.precision);
  yaml << YAML::Key << "dt_critical_s" << YAML::Value << plan.dt_critical_s;
  yaml << YAML::Key << "safety" << YAML::Value << plan.safety;
  yaml << YAML::Key << "refused" << YAML::Value << plan.refused;
  yaml << YAML::Key << "load_average" << YAML::Value << load_average;
  yaml << YAML::Key << "error" << YAML::Value << error;
  yaml << YAML::EndMap;
  const std::string path = dir + "/" + kPointFile;
  std::ofstream out(path);
  out << "# A point of `dynaguide eval runtime`: what it is (run.h5 beside it is what happened)\n"
      << yaml.c_str() << "\n";
  if (!out) throw Error("cannot write the point's description", path, "check the output directory is writable");
}

struct PointFile {
  PointPlan plan;
  std::string scene_name, error;
  double load_average = 0;
};

PointFile ReadPointFile(const std::string& path) {
  try {
    const YAML::Node yaml = YAML::LoadFile(path);
    PointFile file;
    file.scene_name = yaml["scene_name"].as<std::string>();
    file.error = yaml["error"].as<std::string>();
    file.load_average = yaml["load_average"].as<double>();
    PointPlan& plan = file.plan;
    plan.scene = yaml["scene"].as<std::string>();
    plan.point.target_tets = yaml["target_tets"].as<int>();
    plan.point.dt_s = yaml["dt_s"].as<double>();
    plan.point.target_features = yaml["target_features"].as<int>();
    plan.point.threads = yaml["threads"].as<int>();
    plan.point.precision = sim::ParsePrecision(
        yaml["precision"].as<std::string>(sim::ToString(sim::Precision::kFloat)), path + " (precision)");
    plan.tets = yaml["tets"].as<int>();
    plan.nodes = yaml["nodes"].as<int>();
    plan.dt_critical_s = yaml["dt_critical_s"].as<double>();
    plan.safety = yaml["safety"].as<double>();
    plan.refused = yaml["refused"].as<bool>();
    return file;
  } catch (const YAML::Exception& e) {
    throw Error("not a sweep point's description: " + std::string(e.what()), path,
                "remove the directory, or run `dynaguide eval runtime` into a fresh --out");
  }
}

// The run log's cost: the whole run's and the simulating real-time factors,
// and each stage's timing statistics over the simulated frames (over all
// frames, the registration window's would make the simulation's median zero).
void ReadPointCost(const SavedRun& saved, const RunErrors& errors, PointResult* point) {
  point->realtime_factor = saved.statistics.realtime_factor;
  if (errors.frame.empty()) return;
  std::vector<pipeline::StageTiming> simulated;
  for (const pipeline::StageTiming& t : saved.timings) {
    if (t.frame >= errors.frame.front() && t.frame <= errors.frame.back()) simulated.push_back(t);
  }
  point->stages = pipeline::Summarize(simulated, saved.stage_names, 0, 0, errors.fps, true).stages;
  point->simulating_realtime_factor =
      SimulatingRealtimeFactor(saved.timings, static_cast<int>(saved.stage_names.size()) - 1, errors.frame.front(),
                               errors.frame.back(), errors.fps);
}

std::string Duration(double seconds) {
  return seconds < 120 ? Printed("%.0f s", seconds) : Printed("%.1f min", seconds / 60);
}

}  // namespace

std::string SweepPoint::Name() const {
  return (target_tets > 0 ? "tets" + std::to_string(target_tets) : std::string("tets-own")) +
         Printed("_dt%.2fms_f%d_threads%d", dt_s * 1e3, target_features, threads) +
         (precision == sim::Precision::kDouble ? "_double" : "");
}

std::vector<SweepPoint> DesignSweep(bool quick) {
  if (quick) {
    // The tiny phantom's 1.5k mesh at three steps, and a finer mesh through the variant path.
    return {{0, 1e-4, 500, 2},
            {0, 2e-4, 500, 2},
            {0, 4e-4, 500, 2},
            {3000, 2e-4, 500, 2},
            {0, 2e-4, 500, 2, sim::Precision::kDouble}};
  }
  // The default phantom's own mesh is the generator's 8k: the baseline.
  std::vector<SweepPoint> points = {{0, 2e-4, 500, 2}};
  for (int tets : {2000, 4000, 16000, 32000}) points.push_back({tets, 2e-4, 500, 2});
  for (double dt_s : {1e-4, 3e-4, 4e-4, 5e-4}) points.push_back({0, dt_s, 500, 2});
  for (int features : {250, 1000}) points.push_back({0, 2e-4, features, 2});
  points.push_back({0, 2e-4, 500, 1});
  points.push_back({0, 2e-4, 500, 2, sim::Precision::kDouble});
  // Toward real time: coarser meshes with longer steps, on two cores and one;
  // and a finer mesh at the longest step its limit allows (about 0.35 ms on
  // the default phantom: 0.3 ms is safe, 0.4 ms refused).
  for (const SweepPoint& combination : {SweepPoint{4000, 4e-4, 500, 2}, SweepPoint{4000, 4e-4, 500, 1},
                                        SweepPoint{2000, 5e-4, 500, 2}, SweepPoint{16000, 3e-4, 500, 2}}) {
    points.push_back(combination);
  }
  return points;
}

double SimulatingRealtimeFactor(const std::vector<pipeline::StageTiming>& timings, int sink_stage,
                                std::int64_t first_frame, std::int64_t last_frame, double fps) {
  std::int64_t first_end_ns = -1, last_end_ns = -1;
  for (const pipeline::StageTiming& t : timings) {
    if (t.stage != sink_stage) continue;
    if (t.frame == first_frame) first_end_ns = t.end_ns;
    if (t.frame == last_frame) last_end_ns = t.end_ns;
  }
  if (last_frame <= first_frame || first_end_ns < 0 || last_end_ns <= first_end_ns || !(fps > 0)) return 0;
  return (last_frame - first_frame) / fps / ((last_end_ns - first_end_ns) * 1e-9);
}

std::vector<bool> ParetoFront(const std::vector<CostAccuracy>& points, double error_tolerance_mm) {
  std::vector<bool> front(points.size(), true);
  for (size_t i = 0; i < points.size(); ++i) {
    for (size_t j = 0; j < points.size() && front[i]; ++j) {
      const CostAccuracy &a = points[i], &b = points[j];
      const bool no_worse = b.realtime_factor >= a.realtime_factor && b.error_mm <= a.error_mm + error_tolerance_mm;
      const bool better = b.realtime_factor > a.realtime_factor || b.error_mm < a.error_mm - error_tolerance_mm;
      if (no_worse && better) front[i] = false;
    }
  }
  return front;
}

std::optional<size_t> RecommendForRealTime(const std::vector<PointResult>& points, int threads) {
  const auto keeps_up = [&](const PointResult& p) {
    return p.ran && p.plan.point.threads == threads && p.simulating_realtime_factor >= 1;
  };
  double best_error_mm = INFINITY;
  for (const PointResult& p : points) {
    if (keeps_up(p)) best_error_mm = std::min(best_error_mm, StudyInternalRmsMm(p.errors));
  }
  std::optional<size_t> fastest;
  for (size_t k = 0; k < points.size(); ++k) {
    const PointResult& p = points[k];
    if (!keeps_up(p) || StudyInternalRmsMm(p.errors) > best_error_mm + kSameErrorMm) continue;
    if (!fastest || p.simulating_realtime_factor > points[*fastest].simulating_realtime_factor) fastest = k;
  }
  return fastest;
}

RuntimeResult RunRuntimeSweep(const RuntimeOptions& options) {
  const std::string scene_file = options.scene.empty()
                                     ? CachedPhantomScenePath(options.quick ? "tiny" : "default", 1, options.progress)
                                     : options.scene;
  const io::Scene scene = io::ReadScene(scene_file);
  if (scene.truth.empty() || !scene.preoperative || !scene.simulation) {
    throw Error("the scene has no ground truth, preoperative scan or simulation", scene_file,
                "sweep a phantom scene (dynaguide phantom writes one)");
  }
  const std::vector<SweepPoint> design = DesignSweep(options.quick);
  std::vector<PointPlan> plans;
  for (const SweepPoint& point : design) {
    if (options.progress) {
      std::fprintf(stderr, "eval runtime: planning %zu / %zu, %s\n", plans.size() + 1, design.size(),
                   point.Name().c_str());
    }
    plans.push_back(PlanPoint(scene, point));
    const PointPlan& plan = plans.back();
    const std::string dir = options.out_dir + "/runs/" + point.Name();
    fs::create_directories(dir);
    fs::remove(dir + "/run.h5");  // a log of an earlier sweep would pass for this one's
    WritePointFile(dir, scene.name, plan, 0, "");
    if (plan.refused && options.progress) {
      std::fprintf(stderr, "eval runtime: %s refused by the guard: dt %.2f ms > %.2f x dt_cr %.3f ms (not run)\n",
                   point.Name().c_str(), point.dt_s * 1e3, plan.safety,
                   plan.dt_critical_s * 1e3);
    }
  }

  if (!options.emit_jobs.empty()) {
    std::ofstream jobs(options.emit_jobs);
    for (const PointPlan& plan : plans) {
      if (plan.refused) continue;
      jobs << ShellWord(options.program) << " run " << ShellWord(plan.scene) << " --out "
           << ShellWord(options.out_dir + "/runs/" + plan.point.Name())
           << " --no-video --features " << plan.point.target_features << " --threads " << plan.point.threads << "\n";
    }
    if (!jobs) throw Error("cannot write the job list", options.emit_jobs, "check the directory exists");
    return {};
  }

  const auto start = std::chrono::steady_clock::now();
  const long runnable = std::count_if(plans.begin(), plans.end(), [](const PointPlan& p) { return !p.refused; });
  long done = 0;
  for (const PointPlan& plan : plans) {
    if (plan.refused) continue;
    const std::string dir = options.out_dir + "/runs/" + plan.point.Name();
    if (options.progress) {
      const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::fprintf(stderr, "eval runtime: run %ld / %ld, %s (%s elapsed%s)\n", done + 1, runnable,
                   plan.point.Name().c_str(), Duration(elapsed_s).c_str(),
                   done > 0 ? (", about " + Duration(elapsed_s / done * (runnable - done)) + " to go").c_str() : "");
    }
    const double load_average = LoadAverage();
    pipeline::RunOptions run;
    run.scene = plan.scene;
    run.out_dir = dir;
    run.threads = plan.point.threads;
    run.front_end.target_features = plan.point.target_features;
    run.video = false;
    run.progress = options.progress;
    std::string error;
    try {
      pipeline::RunScene(run);
    } catch (const Error& e) {
      // One failed point (e.g. a blow-up the estimate did not foresee) is a finding, not the end of the sweep.
      error = e.what();
      if (options.progress) std::fprintf(stderr, "eval runtime: %s failed: %s\n", plan.point.Name().c_str(), e.what());
    }
    WritePointFile(dir, scene.name, plan, load_average, error);
    ++done;
  }
  return ReadRuntimeLogs(options.out_dir, options.cycles);
}

bool IsRuntimeSweepDir(const std::string& dir) {
  std::error_code error;
  for (fs::directory_iterator it(fs::path(dir) / "runs", error), end; !error && it != end; it.increment(error)) {
    if (fs::exists(it->path() / kPointFile)) return true;
  }
  return false;
}

RuntimeResult ReadRuntimeLogs(const std::string& dir, double cycles) {
  std::vector<PointFile> files;
  std::error_code error;
  for (fs::directory_iterator it(fs::path(dir) / "runs", error), end; !error && it != end; it.increment(error)) {
    const fs::path point_file = it->path() / kPointFile;
    if (fs::exists(point_file)) files.push_back(ReadPointFile(point_file.string()));
  }
  if (files.empty()) {
    throw Error("no sweep point found", dir + "/runs",
                "run `dynaguide eval runtime --out " + dir + "` (or its --emit-jobs jobs) first");
  }
  std::sort(files.begin(), files.end(), [](const PointFile& a, const PointFile& b) {
    return std::tuple(a.plan.tets, a.plan.point.dt_s, a.plan.point.target_features, a.plan.point.threads,
                      a.plan.point.precision) < std::tuple(b.plan.tets, b.plan.point.dt_s,
                                                           b.plan.point.target_features, b.plan.point.threads,
                                                           b.plan.point.precision);
  });

  RuntimeResult result;
  result.scene_name = files.front().scene_name;
  std::vector<RunErrors> runs;  // beside result.points; empty for a point not run
  for (const PointFile& file : files) {
    if (file.scene_name != result.scene_name) {
      throw Error("the sweep's points come from two scenes, " + result.scene_name + " and " + file.scene_name,
                  dir + "/runs/" + file.plan.point.Name(), "sweep each scene into its own --out directory");
    }
    PointResult point;
    point.plan = file.plan;
    point.load_average = file.load_average;
    point.error = file.error;
    const std::string log = dir + "/runs/" + file.plan.point.Name() + "/run.h5";
    runs.emplace_back();
    if (file.error.empty() && fs::exists(log)) {
      // A job run elsewhere records its failure in its log, not in point.yaml.
      const SavedRun saved = ReadSavedRun(log);
      point.error = saved.error;
      point.machine = io::H5Reader(log).ReadAttribute<std::string>("/", "machine");
      if (point.error.empty()) {
        runs.back() = ReadRunErrors(log);
        point.ran = true;
        ReadPointCost(saved, runs.back(), &point);
      }
    }
    result.points.push_back(std::move(point));
  }

  // The protocol's window: `cycles` periods from the simulation's start, as far as every run reaches.
  result.window_frames = -1;
  for (const RunErrors& run : runs) {
    if (run.path.empty()) continue;
    const int wanted = static_cast<int>(std::lround(cycles * run.period_s * run.fps));
    const int reach = std::min(wanted, static_cast<int>(run.frame.size()));
    result.window_frames = result.window_frames < 0 ? reach : std::min(result.window_frames, reach);
  }
  std::vector<CostAccuracy> measured;
  std::vector<size_t> measured_index;
  for (size_t k = 0; k < result.points.size(); ++k) {
    if (!result.points[k].ran) continue;
    result.points[k].errors = Figures({&runs[k]}, result.window_frames);
    measured.push_back({result.points[k].simulating_realtime_factor, StudyInternalRmsMm(result.points[k].errors)});
    measured_index.push_back(k);
  }
  const std::vector<bool> front = ParetoFront(measured, kSameErrorMm);
  for (size_t m = 0; m < measured.size(); ++m) result.points[measured_index[m]].pareto = front[m];
  result.recommended = RecommendForRealTime(result.points);
  return result;
}

}  // namespace dg::tools
