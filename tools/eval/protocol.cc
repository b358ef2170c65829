#include "tools/eval/protocol.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <tuple>

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "io/h5_file.h"
#include "io/registration_file.h"
#include "io/scene.h"
#include "pipeline/run_scene.h"
#include "sim/error.h"
#include "sim/statistics.h"
#include "tools/job_program.h"
#include "tools/json_text.h"
#include "tools/report/line_plot.h"
#include "tools/phantom/phantom_cache.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;

// The paper's Table 1 (mm): surface overlay in the left image, internal overlay in 3D.
struct PaperRow {
  double surface_avg, surface_max, surface_rms, internal_avg, internal_max, internal_rms;
};
const std::map<sim::SimulationMode, PaperRow> kPaperTable1 = {
    {sim::SimulationMode::kSurface, {0.33, 0.64, 0.36, 1.05, 2.16, 1.21}},
    {sim::SimulationMode::kVolume, {0.69, 1.40, 0.80, 0.16, 0.32, 0.18}},
    {sim::SimulationMode::kCombined, {0.36, 0.68, 0.40, 0.83, 1.75, 0.92}}};
// Its Table 2 (mm): the five fiducials' errors of the deformed scan and of the volume-mode simulation.
const std::vector<double> kPaperDeformed = {0.23, 0.31, 0.20, 0.23, 0.23};
const std::vector<double> kPaperVolume = {0.25, 0.30, 0.20, 0.23, 0.33};
constexpr double kPaperResidualMm = 0.47;

std::vector<std::string> SceneFiles(const ProtocolOptions& options) {
  if (!options.scene.empty()) {
    if (options.beat.any()) {
      throw Error("the beat options make phantoms from seeds, and a scene was given", options.scene,
                  "give --seeds without a scene, or make the scene with `dynaguide phantom` and its beat options");
    }
    return {options.scene};
  }
  std::vector<std::string> scenes;
  for (std::uint64_t seed : options.seeds) {
    scenes.push_back(CachedPhantomScenePath("default", seed, options.progress, options.beat));
  }
  return scenes;
}

// The truth's registration as a registration file beside the scene.
std::string WriteTruthRegistration(const io::Scene& scene) {
  const io::H5Reader truth(scene.truth);
  io::Registration registration;
  registration.T_C_S = truth.ReadMatrix("/T_C_S");
  registration.phase_shift_s = truth.ReadScalar("/phase_shift_s");
  registration.period_s = truth.ReadScalar("/period_s");
  const std::string file = "eval-truth-registration.yaml";
  io::WriteRegistrationYaml((fs::path(scene.path).parent_path() / file).string(), registration);
  return file;
}

// The scene in one mode, beside the original (its relative paths still
// resolve), without overlays: the errors do not depend on drawing them;
// with the truth's registration, or with the registration's constant phase
// shift instead of the live phase, when the options ask.
std::string WriteModeScene(const io::Scene& scene, sim::SimulationMode mode, const ProtocolOptions& options) {
  const std::string& scene_file = scene.path;
  YAML::Node root = YAML::Load(scene.text);
  root["simulation"]["mode"] = sim::ToString(mode);
  root.remove("overlays");
  if (options.truth_registration) {
    root.remove("registration");
    root["registration"]["file"] = WriteTruthRegistration(scene);
  } else if (options.constant_phase) {
    root["registration"]["live_phase"] = false;
  }
  const std::string name = "eval-" + sim::ToString(mode) + (options.constant_phase ? "-constant-phase" : "") + ".yaml";
  const std::string path = (fs::path(scene_file).parent_path() / name).string();
  std::ofstream out(path);
  out << "# " << scene_file << " in " << sim::ToString(mode) << " mode, for `dynaguide eval protocol`\n"
      << YAML::Dump(root) << "\n";
  if (!out) throw Error("cannot write the mode's scene", path, "make the scene's directory writable");
  return path;
}

std::string Fixed(double value, int digits = 2) {
  char text[32];
  std::snprintf(text, sizeof text, "%.*f", digits, value);
  return text;
}

std::vector<const RunErrors*> RunsOfMode(const ProtocolResult& result, sim::SimulationMode mode) {
  std::vector<const RunErrors*> runs;
  for (const RunErrors& run : result.runs) {
    if (run.mode == mode) runs.push_back(&run);
  }
  return runs;
}

// The phase figures of a mode's runs, when they had a live phase and a truth.
void AddPhaseJson(const ErrorFigures& f, nlohmann::ordered_json* json) {
  if (f.phase_frames == 0) return;
  (*json)["phase_frames"] = f.phase_frames;
  (*json)["phase_error_mean_ms"] = Significant(f.phase_error_mean_ms, 6);
  (*json)["phase_error_max_ms"] = Significant(f.phase_error_max_ms, 6);
  (*json)["registered_phase_error_mean_ms"] = Significant(f.registered_phase_error_mean_ms, 6);
  (*json)["registered_phase_error_max_ms"] = Significant(f.registered_phase_error_max_ms, 6);
}

// Table 1's surface columns by the paper's statistic: one typical feature
// through the window (ErrorFigures::typical_*), beside the maximum over all
// visible points.
void AppendTypicalFeatureTable(const ProtocolResult& result, std::string* md) {
  *md += "## The paper's statistic: one typical surface feature (mm)\n\n"
         "| mode | points seen throughout | typical avg | max | RMS | all visible points max |\n"
         "|---|---:|---:|---:|---:|---:|\n";
  for (size_t m = 0; m < ProtocolModes().size(); ++m) {
    const ErrorFigures& f = result.per_mode[m];
    if (!result.mode_ran[m]) continue;
    const PaperRow& paper = kPaperTable1.at(ProtocolModes()[m]);
    *md += "| " + sim::ToString(ProtocolModes()[m]) + " | " + std::to_string(f.typical_points) + " | " +
           Fixed(f.typical_avg_mm) + " (" + Fixed(paper.surface_avg) + ") | " + Fixed(f.typical_max_mm) + " (" +
           Fixed(paper.surface_max) + ") | " + Fixed(f.typical_rms_mm) + " (" + Fixed(paper.surface_rms) + ") | " +
           Fixed(f.surface_max_mm) + " |\n";
  }
  *md += "\nThe paper follows \"a typical feature manually tracked in the left video stream\". Here it is the "
         "surface point with the median RMS error among those the left camera sees in every frame of the window "
         "(per scene; pooled over scenes). Table 1 above takes every visible point, a stricter statistic "
         "(docs/studies/surface_max.md).\n\n";
}

// The cardiac phase against the truth per mode, when the runs estimated it live.
void AppendPhaseTable(const ProtocolResult& result, std::string* md) {
  bool any = false;
  for (const ErrorFigures& f : result.per_mode) any = any || f.phase_frames > 0;
  if (!any) return;
  *md += "## Cardiac phase against the truth (ms), every frame from the registration on\n\n"
         "| mode | frames | live mean | live max | constant shift mean | constant shift max |\n"
         "|---|---:|---:|---:|---:|---:|\n";
  for (size_t m = 0; m < ProtocolModes().size(); ++m) {
    const ErrorFigures& f = result.per_mode[m];
    if (!result.mode_ran[m] || f.phase_frames == 0) continue;
    *md += "| " + sim::ToString(ProtocolModes()[m]) + " | " + std::to_string(f.phase_frames) + " | " +
           Fixed(f.phase_error_mean_ms) + " | " + Fixed(f.phase_error_max_ms) + " | " +
           Fixed(f.registered_phase_error_mean_ms) + " | " + Fixed(f.registered_phase_error_max_ms) + " |\n";
  }
  *md += "\nLive: the phase estimated every frame from the tracked fiducials (docs/phase.md); constant shift: the "
         "registration's (t + lambda) / T.\n\n";
}

void WritePlots(const ProtocolResult& result, const std::string& out_dir) {
  // The first scene's runs: one time axis.
  const std::string& scene = result.scenes.front();
  std::vector<PlotSeries> surface, internal;
  for (sim::SimulationMode mode : ProtocolModes()) {
    for (const RunErrors& run : result.runs) {
      if (run.mode != mode || run.scene_name != scene) continue;
      PlotSeries s{sim::ToString(mode), {}}, i{sim::ToString(mode), {}};
      const size_t rows = std::min(run.frame.size(), static_cast<size_t>(result.window_frames));
      for (size_t r = 0; r < rows; ++r) {
        s.points.push_back({run.t_s[r], run.surface_mean_mm[r]});
        double sum = 0;
        for (int p = 0; p < run.internal_points; ++p) sum += run.internal_mm[r * run.internal_points + p];
        i.points.push_back({run.t_s[r], sum / std::max(1, run.internal_points)});
      }
      surface.push_back(std::move(s));
      internal.push_back(std::move(i));
    }
  }
  PlotOptions options;
  options.x_label = "video time (s), " + scene;
  options.y_label = "surface overlay error, left image (mm, mean over the visible points)";
  options.references = {{"paper, combined avg", kPaperTable1.at(sim::SimulationMode::kCombined).surface_avg}};
  WriteLinePlot(surface, options, out_dir + "/fig2_surface.png");
  options.y_label = "internal overlay error, 3D (mm, mean over the internal points)";
  options.references = {{"paper, combined avg", kPaperTable1.at(sim::SimulationMode::kCombined).internal_avg}};
  WriteLinePlot(internal, options, out_dir + "/fig2_internal.png");
}

// Table 2 from the volume mode's figures: the fiducials' errors beside the paper's.
void AppendTable2(const ErrorFigures& volume, std::string* md_out, std::string* csv2) {
  std::string& md = *md_out;
  const size_t F = volume.fiducial_sim_avg_mm.size();
  md += "| | ";
  for (size_t i = 0; i < F; ++i) md += "fiducial " + std::to_string(i + 1) + " | ";
  md += "average |\n|---|";
  for (size_t i = 0; i <= F; ++i) md += "---:|";
  md += "\n";
  for (const auto& [label, values, paper] :
       {std::tuple{"deformed scan", &volume.fiducial_model_avg_mm, &kPaperDeformed},
        std::tuple{"volume", &volume.fiducial_sim_avg_mm, &kPaperVolume}}) {
    md += std::string("| ") + label + " | ";
    double sum = 0;
    for (size_t i = 0; i < F; ++i) {
      md += Fixed((*values)[i]) + (i < paper->size() ? " (" + Fixed((*paper)[i]) + ")" : "") + " | ";
      sum += (*values)[i];
    }
    double paper_sum = 0;
    for (double v : *paper) paper_sum += v;
    md += Fixed(F ? sum / F : 0) + " (" + Fixed(paper_sum / paper->size()) + ") |\n";
  }
  for (size_t i = 0; i < F; ++i) {
    *csv2 += std::to_string(i + 1) + "," + Fixed(volume.fiducial_model_avg_mm[i], 6) + "," +
             Fixed(volume.fiducial_sim_avg_mm[i], 6) + "\n";
  }
  md += "\nDeformed scan: the scan's per-phase fiducial positions interpolated linearly in time at the registered "
        "phase; volume: the fiducials embedded in the volume-mode simulation. Both through the run's registration.\n\n";
}

}  // namespace

const std::vector<sim::SimulationMode>& ProtocolModes() {
  static const std::vector<sim::SimulationMode> modes = {sim::SimulationMode::kSurface, sim::SimulationMode::kVolume,
                                                         sim::SimulationMode::kCombined};
  return modes;
}

ProtocolResult RunProtocol(const ProtocolOptions& options) {
  if (!(options.cycles > 0)) throw Error("the window must be positive", "--cycles", "evaluate over 3 cycles, as the paper");
  const std::string runs_dir = options.out_dir + "/runs";
  std::ofstream jobs;
  if (!options.emit_jobs.empty()) {
    jobs.open(options.emit_jobs);
    if (!jobs) throw Error("cannot write the job list", options.emit_jobs, "check the directory exists");
  }
  for (const std::string& scene_file : SceneFiles(options)) {
    const io::Scene scene = io::ReadScene(scene_file);  // validates, and names what is missing
    if (scene.truth.empty() || !scene.preoperative) {
      throw Error("the scene has no ground truth or no preoperative scan", scene_file,
                  "evaluate a phantom scene (dynaguide phantom writes truth.h5 and scan.h5)");
    }
    const std::string& name = scene.name;
    for (sim::SimulationMode mode : ProtocolModes()) {
      pipeline::RunOptions run;
      run.scene = WriteModeScene(scene, mode, options);
      run.out_dir = runs_dir + "/" + name + "/" + sim::ToString(mode);
      run.threads = options.threads;
      run.video = false;
      run.progress = options.progress;
      if (jobs.is_open()) {
        jobs << ShellWord(options.program) << " run " << ShellWord(run.scene) << " --out " << ShellWord(run.out_dir)
             << " --no-video"
             << (options.threads > 0 ? " --threads " + std::to_string(options.threads) : "") << "\n";
        continue;
      }
      if (options.progress) {
        std::fprintf(stderr, "eval protocol: %s, %s mode\n", name.c_str(), sim::ToString(mode).c_str());
      }
      pipeline::RunScene(run);
    }
  }
  if (jobs.is_open()) return {};
  return ReadProtocolLogs(runs_dir, options.cycles);
}

ProtocolResult ReadProtocolLogs(const std::string& dir, double cycles) {
  ProtocolResult result;
  std::error_code error;
  for (fs::recursive_directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) {
    if (it->path().filename() == "run.h5") result.runs.push_back(ReadRunErrors(it->path().string()));
  }
  if (result.runs.empty()) {
    throw Error("no run log found", dir, "run `dynaguide eval protocol`, or the jobs of --emit-jobs, into it first");
  }
  // Scenes in name order, modes in the protocol's.
  std::sort(result.runs.begin(), result.runs.end(), [](const RunErrors& a, const RunErrors& b) {
    const auto rank = [](sim::SimulationMode mode) {
      return std::find(ProtocolModes().begin(), ProtocolModes().end(), mode) - ProtocolModes().begin();
    };
    return std::pair(a.scene_name, rank(a.mode)) < std::pair(b.scene_name, rank(b.mode));
  });
  // The window: `cycles` periods from each simulation's start, as far as every run reaches.
  const RunErrors& first = result.runs.front();
  result.window_frames = static_cast<int>(std::lround(cycles * first.period_s * first.fps));
  for (const RunErrors& run : result.runs) {
    result.window_frames = std::min(result.window_frames, static_cast<int>(run.frame.size()));
    if (result.scenes.empty() || result.scenes.back() != run.scene_name) result.scenes.push_back(run.scene_name);
  }
  result.window_cycles = result.window_frames / (first.period_s * first.fps);
  for (sim::SimulationMode mode : ProtocolModes()) {
    const std::vector<const RunErrors*> runs = RunsOfMode(result, mode);
    result.mode_ran.push_back(!runs.empty());
    result.per_mode.push_back(runs.empty() ? ErrorFigures{} : Figures(runs, result.window_frames));
  }
  return result;
}

std::string WriteProtocolReport(const ProtocolResult& result, const std::string& out_dir) {
  fs::create_directories(out_dir);
  std::string md = "# dynaguide eval protocol\n\n";
  md += "Scenes: " + std::to_string(result.scenes.size()) + " (";
  for (size_t k = 0; k < result.scenes.size(); ++k) md += (k ? ", " : "") + result.scenes[k];
  md += "). Window: " + std::to_string(result.window_frames) + " frames (" + Fixed(result.window_cycles) +
        " cardiac cycles) from the first simulated frame, " +
        (result.runs.front().registration_given ? "with the registration the scene gives (e.g. --truth-registration)"
                                                : "registered from the video") +
        ".\n\n";

  md += "## Table 1: overlay errors (mm), this run against the paper\n\n";
  md += "| mode | surface avg | max | RMS | internal avg | max | RMS | real-time factor |\n";
  md += "|---|---:|---:|---:|---:|---:|---:|---:|\n";
  std::string csv1 = "mode,surface_avg_mm,surface_max_mm,surface_rms_mm,internal_avg_mm,internal_max_mm,internal_rms_mm,"
                     "realtime_factor,frames,typical_surface_avg_mm,typical_surface_max_mm,typical_surface_rms_mm\n";
  for (size_t m = 0; m < ProtocolModes().size(); ++m) {
    const sim::SimulationMode mode = ProtocolModes()[m];
    const std::string name = sim::ToString(mode);
    if (!result.mode_ran[m]) {
      md += "| " + name + " | not run | | | | | | |\n";
      continue;
    }
    const ErrorFigures& f = result.per_mode[m];
    const PaperRow& paper = kPaperTable1.at(mode);
    std::vector<double> factors;
    for (const RunErrors* run : RunsOfMode(result, mode)) factors.push_back(run->realtime_factor);
    md += "| " + name + " | " + Fixed(f.surface_avg_mm) + " (" + Fixed(paper.surface_avg) + ") | " +
          Fixed(f.surface_max_mm) + " (" + Fixed(paper.surface_max) + ") | " + Fixed(f.surface_rms_mm) + " (" +
          Fixed(paper.surface_rms) + ") | " + Fixed(f.internal_avg_mm) + " (" + Fixed(paper.internal_avg) + ") | " +
          Fixed(f.internal_max_mm) + " (" + Fixed(paper.internal_max) + ") | " + Fixed(f.internal_rms_mm) + " (" +
          Fixed(paper.internal_rms) + ") | " + Fixed(sim::Median(factors)) + " |\n";
    csv1 += name + "," + Fixed(f.surface_avg_mm, 6) + "," + Fixed(f.surface_max_mm, 6) + "," +
            Fixed(f.surface_rms_mm, 6) + "," + Fixed(f.internal_avg_mm, 6) + "," + Fixed(f.internal_max_mm, 6) + "," +
            Fixed(f.internal_rms_mm, 6) + "," + Fixed(sim::Median(factors), 4) + "," + std::to_string(f.frames) + "," +
            Fixed(f.typical_avg_mm, 6) + "," + Fixed(f.typical_max_mm, 6) + "," + Fixed(f.typical_rms_mm, 6) + "\n";
  }
  md += "\nIn parentheses the paper's (CABG phantom, da Vinci video). Surface: the phantom's surface points the left "
        "camera sees, where the overlay draws them against where they are, in mm at their depth; internal: the "
        "embedded internal points against their true positions in 3D.\n\n";
  AppendTypicalFeatureTable(result, &md);

  md += "## Table 2: fiducial errors (mm), averaged over the window\n\n";
  std::string csv2 = "fiducial,deformed_scan_mm,volume_mm\n";
  if (result.mode_ran[1]) {
    AppendTable2(result.per_mode[1], &md, &csv2);
  } else {
    md += "Not run: Table 2 is the volume mode's, and no run log here is of that mode.\n\n";
  }
  AppendPhaseTable(result, &md);

  md += "## Registration residuals (mean, mm at the fiducials' depth)\n\n| scene | mode | left | right |\n"
        "|---|---|---:|---:|\n";
  for (const RunErrors& run : result.runs) {
    md += "| " + run.scene_name + " | " + sim::ToString(run.mode) + " | " + Fixed(run.residual_mm_left, 3) + " | " +
          Fixed(run.residual_mm_right, 3) + " |\n";
  }
  md += "\nThe paper: " + Fixed(kPaperResidualMm) + " mm left and right.\n\n";
  md += "Fig. 2: fig2_surface.png and fig2_internal.png (error against time per mode).\n";

  WritePlots(result, out_dir);
  for (const auto& [file, text] : {std::pair{"/report.md", &md}, std::pair{"/table1.csv", &csv1},
                                   std::pair{"/table2.csv", &csv2}}) {
    std::ofstream out(out_dir + file);
    out << *text;
    if (!out) throw Error("cannot write the report", out_dir + file, "check the directory is writable");
  }
  return md;
}

void WriteProtocolJson(const ProtocolResult& result, const std::string& path) {
  using Json = nlohmann::ordered_json;
  Json modes = Json::array();  // a mode no run log is of has no entry: its figures do not exist
  for (size_t m = 0; m < ProtocolModes().size(); ++m) {
    if (!result.mode_ran[m]) continue;
    const ErrorFigures& f = result.per_mode[m];
    std::vector<double> factors;
    for (const RunErrors* run : RunsOfMode(result, ProtocolModes()[m])) factors.push_back(run->realtime_factor);
    Json mode = {{"mode", sim::ToString(ProtocolModes()[m])},
                 {"surface_avg_mm", Significant(f.surface_avg_mm, 6)},
                 {"surface_max_mm", Significant(f.surface_max_mm, 6)},
                 {"surface_rms_mm", Significant(f.surface_rms_mm, 6)},
                 {"internal_avg_mm", Significant(f.internal_avg_mm, 6)},
                 {"internal_max_mm", Significant(f.internal_max_mm, 6)},
                 {"internal_rms_mm", Significant(f.internal_rms_mm, 6)},
                 {"realtime_factor", Significant(sim::Median(factors), 6)},
                 {"frames", f.frames},
                 {"typical_surface_points", f.typical_points},
                 {"typical_surface_avg_mm", Significant(f.typical_avg_mm, 6)},
                 {"typical_surface_max_mm", Significant(f.typical_max_mm, 6)},
                 {"typical_surface_rms_mm", Significant(f.typical_rms_mm, 6)}};
    AddPhaseJson(f, &mode);
    modes.push_back(std::move(mode));
  }
  const Json json = {{"window_frames", result.window_frames},
                     {"window_cycles", Decimals(result.window_cycles, 4)},
                     {"modes", modes}};
  std::ofstream out(path);
  out << JsonText(json);
  if (!out) throw Error("cannot write the JSON", path, "check the directory exists and is writable");
}

}  // namespace dg::tools
