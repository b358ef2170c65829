#include "tools/eval/runtime_report.h"

#include <algorithm>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "sim/error.h"
#include "sim/tled_solver.h"
#include "tools/bench/bench_json.h"
#include "tools/eval/runtime_plot.h"
#include "tools/json_text.h"
#include "tools/provenance.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;

// What every point shares because the graph fixes it (see runtime_sweep.h).

std::string Status(const PointResult& p) {
  if (p.plan.refused) {
    return Printed("refused by the guard (dt > %.2f x dt_cr %.3f ms)", p.plan.safety,
                   p.plan.dt_critical_s * 1e3);
  }
  if (!p.error.empty()) return "failed: " + p.error;
  return p.ran ? "ran" : "not run yet";
}

// The stages of every run, in the order of their first appearance.
std::vector<std::string> StageNames(const RuntimeResult& result) {
  std::vector<std::string> names;
  for (const PointResult& p : result.points) {
    for (const pipeline::StageStatistics& s : p.stages) {
      if (std::find(names.begin(), names.end(), s.name) == names.end()) names.push_back(s.name);
    }
  }
  return names;
}

double StageMedianMs(const PointResult& p, const std::string& stage) {
  for (const pipeline::StageStatistics& s : p.stages) {
    if (s.name == stage) return s.median_ms;
  }
  return 0;
}

std::string CsvQuoted(const std::string& text) {
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) throw Error("cannot write the report", path, "check the directory is writable");
}

}  // namespace

std::string RecommendationText(const RuntimeResult& result) {
  if (!result.recommended) {
    double fastest = 0;
    for (const PointResult& p : result.points) {
      if (p.ran && p.plan.point.threads == 2) fastest = std::max(fastest, p.simulating_realtime_factor);
    }
    return Printed(
        "No configuration kept up with real time on two threads here (the fastest simulated at %.2fx): "
        "for real time on two cores, coarsen the mesh or lengthen the step beyond this sweep.",
        fastest);
  }
  const PointResult& p = result.points[*result.recommended];
  return Printed(
      "For real time on two cores, pick %s: %d tetrahedra, dt %.2f ms, %s, %d target features, "
      "2 threads, the most accurate point that keeps up (internal RMS %.3f mm as shown, surface RMS %.3f mm, "
      "%.2fx real time while simulating).",
      p.plan.point.Name().c_str(), p.plan.tets, p.plan.point.dt_s * 1e3, sim::ToString(p.plan.point.precision).c_str(),
      p.plan.point.target_features,
      StudyInternalRmsMm(p.errors), p.errors.surface_rms_mm, p.simulating_realtime_factor);
}

std::string WriteRuntimeReport(const RuntimeResult& result, const std::string& out_dir) {
  fs::create_directories(out_dir);
  const std::vector<std::string> stages = StageNames(result);
  std::vector<std::string> machines;  // as the logs name them, without the threads each run used
  double load_min = 1e9, load_max = 0;
  for (const PointResult& p : result.points) {
    if (!p.ran) continue;
    std::string machine = p.machine;
    if (const size_t open = machine.find(" ("), close = machine.find(')', open); close != std::string::npos) {
      machine.erase(open, close - open + 1);
    }
    if (std::find(machines.begin(), machines.end(), machine) == machines.end()) machines.push_back(machine);
    if (p.load_average <= 0) continue;
    load_min = std::min(load_min, p.load_average);
    load_max = std::max(load_max, p.load_average);
  }
  std::string machine_text;
  for (const std::string& m : machines) machine_text += (machine_text.empty() ? "" : "; ") + m;

  std::string md = "# dynaguide eval runtime: error against run time\n\n";
  md += "Scene: " + result.scene_name +
        ". Every point is one `dynaguide run` of the whole graph (registered from "
        "the video, combined mode, the scene's overlays, offline policy, no video file), one point at a time, on " +
        (machine_text.empty() ? std::string("no machine yet (no point has run)") : machine_text) + ". " +
        (load_min <= load_max
             ? Printed("The 1-minute load average was %.1f to %.1f when the points started: ", load_min, load_max) +
                   std::string("timings compare only between points measured under the same load.")
             : std::string("The points ran elsewhere (--emit-jobs): their load is not recorded.")) +
        "\n\n";
  md +=
      "Design: one factor at a time around the baseline (the phantom's own mesh, dt 0.2 ms, 500 target "
      "features, 2 threads, float), plus a few combinations toward real time; not a full factorial. A time "
      "step above the guard's limit is refused, not run (substepping it would measure a smaller step).\n\n";
  md += (result.window_frames < 0
             ? std::string("No point has run yet. ")
             : Printed("Errors over the first %d simulated frames of every run (the protocol's window: --cycles "
                       "cardiac cycles from the simulation's start, as far as every run reaches), mm. ",
                       result.window_frames)) +
        "Real time: video seconds per wall second, over the whole run and over the simulated frames only (the "
        "registration window's frames do not simulate); the Pareto front and the recommendation use the internal RMS "
        "of the overlay as shown (the simulated state's when the scene draws no overlays) against the simulating "
        "factor, errors within " + Printed("%g", kSameErrorMm) + " mm counting as equal.\n\n";

  md +=
      "| point | tets | dt (ms) | features | threads | surface avg | max | RMS | internal avg | max | RMS | real time, "
      "run | "
      "real time, simulating | Pareto |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|:---:|\n";
  std::string csv =
      "point,tets,nodes,dt_ms,threads,precision,target_features,dt_critical_ms,status,surface_avg_mm,"
      "surface_max_mm,surface_rms_mm,internal_avg_mm,internal_max_mm,internal_rms_mm,realtime_factor,"
      "simulating_realtime_factor,pareto,recommended,load_average";
  for (const std::string& stage : stages) csv += "," + stage + "_median_ms";
  csv += "\n";
  for (size_t k = 0; k < result.points.size(); ++k) {
    const PointResult& p = result.points[k];
    const ErrorFigures& e = p.errors;
    const bool recommended = result.recommended == k;
    md += "| " + p.plan.point.Name() + (recommended ? " (recommended)" : "") + " | " + std::to_string(p.plan.tets) +
          " | " + Printed("%.2f", p.plan.point.dt_s * 1e3) + " | " + std::to_string(p.plan.point.target_features) +
          " | " + std::to_string(p.plan.point.threads) + " | ";
    if (p.ran) {
      md += Printed("%.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %.2f | %.2f | %s |\n", e.surface_avg_mm,
                    e.surface_max_mm, e.surface_rms_mm, e.internal_avg_mm, e.internal_max_mm, e.internal_rms_mm,
                    p.realtime_factor, p.simulating_realtime_factor, p.pareto ? "**yes**" : "");
    } else {
      md += Status(p) + " | | | | | | | | |\n";
    }
    csv += p.plan.point.Name() + "," + std::to_string(p.plan.tets) + "," + std::to_string(p.plan.nodes) + "," +
           Printed("%.4f,%d,%s,%d,%.6f,", p.plan.point.dt_s * 1e3, p.plan.point.threads,
                   sim::ToString(p.plan.point.precision).c_str(),
                   p.plan.point.target_features, p.plan.dt_critical_s * 1e3) +
           CsvQuoted(Status(p)) +
           Printed(",%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%d,%d,%.2f", e.surface_avg_mm, e.surface_max_mm,
                   e.surface_rms_mm, e.internal_avg_mm, e.internal_max_mm, e.internal_rms_mm, p.realtime_factor,
                   p.simulating_realtime_factor, p.pareto ? 1 : 0, recommended ? 1 : 0, p.load_average);
    for (const std::string& stage : stages) csv += Printed(",%.4f", StageMedianMs(p, stage));
    csv += "\n";
  }

  if (!stages.empty()) {
    md += "\n## Per-stage median over the simulated frames (ms per frame)\n\n| point |";
    for (const std::string& stage : stages) md += " " + stage + " |";
    md += "\n|---|";
    for (size_t s = 0; s < stages.size(); ++s) md += "---:|";
    md += "\n";
    for (const PointResult& p : result.points) {
      if (!p.ran) continue;
      md += "| " + p.plan.point.Name() + " |";
      for (const std::string& stage : stages) md += Printed(" %.2f |", StageMedianMs(p, stage));
      md += "\n";
    }
  }
  md += "\n## Recommendation\n\n" + RecommendationText(result) + "\n\n";
  md +=
      "Files: runtime.csv (every figure), error_vs_runtime.png (the Pareto front joined, real time marked), "
      "runs/<point>/run.h5 and point.yaml.\n";

  // After --emit-jobs and before its jobs ran, the table lists the points without a plot.
  if (std::any_of(result.points.begin(), result.points.end(),
                  [](const PointResult& p) { return p.ran && p.simulating_realtime_factor > 0; })) {
    WriteErrorRuntimePlot(result, out_dir + "/error_vs_runtime.png");
  }
  WriteText(out_dir + "/report.md", md);
  WriteText(out_dir + "/runtime.csv", csv);
  return md;
}

void WriteRuntimeJson(const RuntimeResult& result, const std::string& path) {
  using Json = nlohmann::ordered_json;
  const RunProvenance run = ReadRunProvenance();
  Json points = Json::array();
  for (size_t k = 0; k < result.points.size(); ++k) {
    const PointResult& p = result.points[k];
    const ErrorFigures& e = p.errors;
    points.push_back({{"name", p.plan.point.Name()},
                      {"tets", p.plan.tets},
                      {"dt_ms", Significant(p.plan.point.dt_s * 1e3, 6)},
                      {"threads", p.plan.point.threads},
                      {"precision", sim::ToString(p.plan.point.precision)},
                      {"target_features", p.plan.point.target_features},
                      {"status", Status(p)},
                      {"surface_avg_mm", Significant(e.surface_avg_mm, 6)},
                      {"surface_max_mm", Significant(e.surface_max_mm, 6)},
                      {"surface_rms_mm", Significant(e.surface_rms_mm, 6)},
                      {"internal_avg_mm", Significant(e.internal_avg_mm, 6)},
                      {"internal_max_mm", Significant(e.internal_max_mm, 6)},
                      {"internal_rms_mm", Significant(e.internal_rms_mm, 6)},
                      {"realtime_factor", Significant(p.realtime_factor, 6)},
                      {"simulating_realtime_factor", Significant(p.simulating_realtime_factor, 6)},
                      {"pareto", p.pareto},
                      {"recommended", result.recommended == k}});
  }
  // The build that wrote the file, when, and the machine's load at the
  // process's start and now (docs/benchmarks.md).
  const Json json = {{"scene", result.scene_name},
                     {"window_frames", result.window_frames},
                     {"commit", run.commit},
                     {"date", run.date},
                     {"load_average_before", LoadAverageJson<Json>(run.load_at_start)},
                     {"load_average_after", LoadAverageJson<Json>(run.load_now)},
                     {"recommendation", RecommendationText(result)},
                     {"points", points}};
  std::ofstream out(path);
  out << JsonText(json);
  if (!out) throw Error("cannot write the JSON", path, "check the directory exists and is writable");
}

}  // namespace dg::tools
