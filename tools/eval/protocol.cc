#include "tools/eval/protocol.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <tuple>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "io/h5_file.h"
#include "io/registration_file.h"
#include "io/scene.h"
#include "pipeline/run_scene.h"
#include "pipeline/stage_graph.h"
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
// resolve), with its overlays: the runs log the errors of the overlay as
// composed beside the state's; with the truth's registration, or with the
// registration's constant phase shift instead of the live phase, when the
// options ask.
std::string WriteModeScene(const io::Scene& scene, sim::SimulationMode mode, const ProtocolOptions& options) {
  const std::string& scene_file = scene.path;
  YAML::Node root = YAML::Load(scene.text);
  root["simulation"]["mode"] = sim::ToString(mode);
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

std::string Fixed(double value, int digits = 2) { return fmt::format("{:.{}f}", value, digits); }

// A figure of the overlay as shown in report.md: n/a where no layer was shown.
std::string ShownCell(double value) { return std::isnan(value) ? "n/a" : Fixed(value); }

// A run's directory under runs/<scene>/: the mode's name, with the policy's after it unless offline.
std::string RunDirName(sim::SimulationMode mode, pipeline::Policy policy) {
  return sim::ToString(mode) +
         (policy == pipeline::Policy::kOffline ? "" : std::string("-") + pipeline::PolicyName(policy));
}

std::vector<const RunErrors*> RunsOf(const ProtocolResult& result, const std::string& policy,
                                     sim::SimulationMode mode) {
  std::vector<const RunErrors*> runs;
  for (const RunErrors& run : result.runs) {
    if (run.policy == policy && run.mode == mode) runs.push_back(&run);
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
         "| mode | policy | points seen throughout | typical avg | max | RMS | all visible points max |\n"
         "|---|---|---:|---:|---:|---:|---:|\n";
  for (const ProtocolEntry& entry : result.entries) {
    if (!entry.ran) continue;
    const ErrorFigures& f = entry.figures;
    const PaperRow& paper = kPaperTable1.at(entry.mode);
    *md += fmt::format("| {} | {} | {} | {} ({}) | {} ({}) | {} ({}) | {} |\n", sim::ToString(entry.mode), entry.policy,
                       f.typical_points, Fixed(f.typical_avg_mm), Fixed(paper.surface_avg), Fixed(f.typical_max_mm),
                       Fixed(paper.surface_max), Fixed(f.typical_rms_mm), Fixed(paper.surface_rms),
                       Fixed(f.surface_max_mm));
  }
  *md += "\nThe paper follows \"a typical feature manually tracked in the left video stream\". Here it is the "
         "surface point with the median RMS error among those the left camera sees in every frame of the window "
         "(per scene; pooled over scenes). Table 1 above takes every visible point, a stricter statistic "
         "(docs/studies/surface_max.md).\n\n";
}

// The cardiac phase against the truth per mode, when the runs estimated it live.
void AppendPhaseTable(const ProtocolResult& result, std::string* md) {
  bool any = false;
  for (const ProtocolEntry& entry : result.entries) any = any || entry.figures.phase_frames > 0;
  if (!any) return;
  *md += "## Cardiac phase against the truth (ms), every frame from the registration on\n\n"
         "| mode | policy | frames | live mean | live max | constant shift mean | constant shift max |\n"
         "|---|---|---:|---:|---:|---:|---:|\n";
  for (const ProtocolEntry& entry : result.entries) {
    const ErrorFigures& f = entry.figures;
    if (!entry.ran || f.phase_frames == 0) continue;
    *md += fmt::format("| {} | {} | {} | {} | {} | {} | {} |\n", sim::ToString(entry.mode), entry.policy,
                       f.phase_frames, Fixed(f.phase_error_mean_ms), Fixed(f.phase_error_max_ms),
                       Fixed(f.registered_phase_error_mean_ms), Fixed(f.registered_phase_error_max_ms));
  }
  *md += "\nLive: the phase estimated every frame from the tracked fiducials (docs/phase.md); constant shift: the "
         "registration's (t + lambda) / T.\n\n";
}

void WritePlots(const ProtocolResult& result, const std::string& out_dir) {
  // The first scene's runs under one policy (offline when it ran): one time
  // axis, and no line hidden under another policy's (the state's errors are
  // the same when no frame was dropped).
  const std::string& scene = result.scenes.front();
  const std::string& policy = result.runs.front().policy;
  std::vector<PlotSeries> surface, internal;
  for (sim::SimulationMode mode : ProtocolModes()) {
    for (const RunErrors* run : RunsOf(result, policy, mode)) {
      if (run->scene_name != scene) continue;
      PlotSeries s{sim::ToString(mode), {}}, i{sim::ToString(mode), {}};
      const size_t rows = WindowRows(*run, result.window_frames);
      for (size_t r = 0; r < rows; ++r) {
        s.points.push_back({run->t_s[r], run->surface_mean_mm[r]});
        double sum = 0;
        for (int p = 0; p < run->internal_points; ++p) sum += run->internal_mm[r * run->internal_points + p];
        i.points.push_back({run->t_s[r], sum / std::max(1, run->internal_points)});
      }
      surface.push_back(std::move(s));
      internal.push_back(std::move(i));
    }
  }
  PlotOptions options;
  options.x_label = "video time (s), " + scene + ", " + policy + " policy";
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

const ProtocolEntry* ProtocolResult::Find(const std::string& policy, sim::SimulationMode mode) const {
  for (const ProtocolEntry& entry : entries) {
    if (entry.policy == policy && entry.mode == mode) return &entry;
  }
  return nullptr;
}

ProtocolResult RunProtocol(const ProtocolOptions& options) {
  if (!(options.cycles > 0)) throw Error("the window must be positive", "--cycles", "evaluate over 3 cycles, as the paper");
  if (options.policies.empty()) throw Error("no policy to run", "--policy", "give offline, realtime or both");
  std::vector<pipeline::Policy> policies;  // parsed before any run: a misspelt policy fails at once
  for (const std::string& name : options.policies) policies.push_back(pipeline::ParsePolicy(name));
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
      const std::string mode_scene = WriteModeScene(scene, mode, options);
      for (pipeline::Policy policy : policies) {
        pipeline::RunOptions run;
        run.scene = mode_scene;
        run.out_dir = runs_dir + "/" + name + "/" + RunDirName(mode, policy);
        run.threads = options.threads;
        run.graph.policy = policy;
        run.video = false;
        run.progress = options.progress;
        if (jobs.is_open()) {
          jobs << fmt::format("{} run {} --out {} --no-video{}{}\n", ShellWord(options.program), ShellWord(run.scene),
                              ShellWord(run.out_dir),
                              policy == pipeline::Policy::kOffline ? "" : " --policy realtime",
                              options.threads > 0 ? fmt::format(" --threads {}", options.threads) : "");
          continue;
        }
        if (options.progress) {
          fmt::print(stderr, "eval protocol: {}, {} mode, {} policy\n", name, sim::ToString(mode),
                     pipeline::PolicyName(policy));
        }
        pipeline::RunScene(run);
      }
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
  // Scenes in name order, then policies ("offline" before "realtime"), modes in the protocol's.
  const auto rank = [](sim::SimulationMode mode) {
    return std::find(ProtocolModes().begin(), ProtocolModes().end(), mode) - ProtocolModes().begin();
  };
  std::sort(result.runs.begin(), result.runs.end(), [&rank](const RunErrors& a, const RunErrors& b) {
    return std::tuple(a.scene_name, a.policy, rank(a.mode)) < std::tuple(b.scene_name, b.policy, rank(b.mode));
  });
  // The window: `cycles` periods from each simulation's start, as far as every
  // run reaches (in frames of the video: a realtime run may have dropped some).
  const RunErrors& first = result.runs.front();
  result.window_frames = static_cast<int>(std::lround(cycles * first.period_s * first.fps));
  std::vector<std::string> policies;
  for (const RunErrors& run : result.runs) {
    const std::int64_t span = run.frame.empty() ? 0 : run.frame.back() - run.frame.front() + 1;
    result.window_frames = static_cast<int>(std::min<std::int64_t>(result.window_frames, span));
    if (result.scenes.empty() || result.scenes.back() != run.scene_name) result.scenes.push_back(run.scene_name);
    if (std::find(policies.begin(), policies.end(), run.policy) == policies.end()) policies.push_back(run.policy);
  }
  std::sort(policies.begin(), policies.end());
  result.window_cycles = result.window_frames / (first.period_s * first.fps);
  for (sim::SimulationMode mode : ProtocolModes()) {
    for (const std::string& policy : policies) {
      ProtocolEntry entry;
      entry.policy = policy;
      entry.mode = mode;
      const std::vector<const RunErrors*> runs = RunsOf(result, policy, mode);
      entry.ran = !runs.empty();
      if (entry.ran) {
        entry.figures = Figures(runs, result.window_frames);
        std::vector<double> factors;
        for (const RunErrors* run : runs) factors.push_back(run->realtime_factor);
        entry.realtime_factor = sim::Median(factors);
      }
      result.entries.push_back(std::move(entry));
    }
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
  md += "| mode | policy | surface avg | max | RMS | internal avg | max | RMS | shown surface avg | max | RMS | "
        "shown internal avg | max | RMS | frames with both layers | real-time factor |\n";
  md += "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  std::string csv1 = "mode,policy,surface_avg_mm,surface_max_mm,surface_rms_mm,internal_avg_mm,internal_max_mm,"
                     "internal_rms_mm,realtime_factor,frames,typical_surface_avg_mm,typical_surface_max_mm,"
                     "typical_surface_rms_mm,shown_frames,shown_surface_avg_mm,shown_surface_max_mm,"
                     "shown_surface_rms_mm,shown_internal_avg_mm,shown_internal_max_mm,shown_internal_rms_mm,"
                     "layer_present_fraction\n";
  for (const ProtocolEntry& entry : result.entries) {
    const std::string name = sim::ToString(entry.mode);
    if (!entry.ran) {
      md += fmt::format("| {} | {} | not run | | | | | | | | | | | | | |\n", name, entry.policy);
      continue;
    }
    const ErrorFigures& f = entry.figures;
    const PaperRow& paper = kPaperTable1.at(entry.mode);
    md += fmt::format("| {} | {} | {} ({}) | {} ({}) | {} ({}) | {} ({}) | {} ({}) | {} ({}) "
                      "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
                      name, entry.policy, Fixed(f.surface_avg_mm), Fixed(paper.surface_avg), Fixed(f.surface_max_mm),
                      Fixed(paper.surface_max), Fixed(f.surface_rms_mm), Fixed(paper.surface_rms),
                      Fixed(f.internal_avg_mm), Fixed(paper.internal_avg), Fixed(f.internal_max_mm),
                      Fixed(paper.internal_max), Fixed(f.internal_rms_mm), Fixed(paper.internal_rms),
                      ShownCell(f.shown_surface_avg_mm), ShownCell(f.shown_surface_max_mm),
                      ShownCell(f.shown_surface_rms_mm), ShownCell(f.shown_internal_avg_mm),
                      ShownCell(f.shown_internal_max_mm), ShownCell(f.shown_internal_rms_mm),
                      ShownCell(f.layer_present_fraction), Fixed(entry.realtime_factor));
    csv1 += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", name, entry.policy,
                        Fixed(f.surface_avg_mm, 6), Fixed(f.surface_max_mm, 6), Fixed(f.surface_rms_mm, 6),
                        Fixed(f.internal_avg_mm, 6), Fixed(f.internal_max_mm, 6), Fixed(f.internal_rms_mm, 6),
                        Fixed(entry.realtime_factor, 4), f.frames, Fixed(f.typical_avg_mm, 6),
                        Fixed(f.typical_max_mm, 6), Fixed(f.typical_rms_mm, 6), f.shown_frames,
                        Fixed(f.shown_surface_avg_mm, 6), Fixed(f.shown_surface_max_mm, 6),
                        Fixed(f.shown_surface_rms_mm, 6), Fixed(f.shown_internal_avg_mm, 6),
                        Fixed(f.shown_internal_max_mm, 6), Fixed(f.shown_internal_rms_mm, 6),
                        Fixed(f.layer_present_fraction, 4));
  }
  md += "\nIn parentheses the paper's (CABG phantom, da Vinci video). Surface: the phantom's surface points the left "
        "camera sees, where the simulated state puts them against where they are, in mm at their depth; internal: "
        "the embedded internal points against their true positions in 3D. Shown: the same over the frames composed "
        "with the overlay's layer drawn from the frame's own state (the surface figures in the texture overlay's "
        "layer, the internal ones in the meshes', else the volume's), what the surgeon sees; n/a where no frame had "
        "the layer. Frames with both layers: their share of the window. Offline runs every frame; realtime is "
        "paced to the video's clock and drops the frames it falls behind on.\n\n";
  AppendTypicalFeatureTable(result, &md);

  md += "## Table 2: fiducial errors (mm), averaged over the window\n\n";
  std::string csv2 = "fiducial,deformed_scan_mm,volume_mm\n";
  const ProtocolEntry* volume = result.Find("offline", sim::SimulationMode::kVolume);
  if (volume && volume->ran) {
    AppendTable2(volume->figures, &md, &csv2);
  } else {
    md += "Not run: Table 2 is the volume mode's (offline), and no run log here is of that mode and policy.\n\n";
  }
  AppendPhaseTable(result, &md);

  md += "## Registration residuals (mean, mm at the fiducials' depth)\n\n| scene | mode | policy | left | right |\n"
        "|---|---|---|---:|---:|\n";
  for (const RunErrors& run : result.runs) {
    md += fmt::format("| {} | {} | {} | {} | {} |\n", run.scene_name, sim::ToString(run.mode), run.policy,
                      Fixed(run.residual_mm_left, 3), Fixed(run.residual_mm_right, 3));
  }
  md += "\nThe paper: " + Fixed(kPaperResidualMm) + " mm left and right.\n\n";
  md += "Fig. 2: fig2_surface.png and fig2_internal.png (error against time per mode, " + result.runs.front().policy +
        " policy).\n";

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
  Json modes = Json::array();  // an entry without runs is left out: its figures do not exist
  for (const ProtocolEntry& entry : result.entries) {
    if (!entry.ran) continue;
    const ErrorFigures& f = entry.figures;
    Json mode = {{"mode", sim::ToString(entry.mode)},
                 {"policy", entry.policy},
                 {"surface_avg_mm", Significant(f.surface_avg_mm, 6)},
                 {"surface_max_mm", Significant(f.surface_max_mm, 6)},
                 {"surface_rms_mm", Significant(f.surface_rms_mm, 6)},
                 {"internal_avg_mm", Significant(f.internal_avg_mm, 6)},
                 {"internal_max_mm", Significant(f.internal_max_mm, 6)},
                 {"internal_rms_mm", Significant(f.internal_rms_mm, 6)},
                 {"shown_frames", f.shown_frames},
                 {"shown_surface_avg_mm", Significant(f.shown_surface_avg_mm, 6)},
                 {"shown_surface_max_mm", Significant(f.shown_surface_max_mm, 6)},
                 {"shown_surface_rms_mm", Significant(f.shown_surface_rms_mm, 6)},
                 {"shown_internal_avg_mm", Significant(f.shown_internal_avg_mm, 6)},
                 {"shown_internal_max_mm", Significant(f.shown_internal_max_mm, 6)},
                 {"shown_internal_rms_mm", Significant(f.shown_internal_rms_mm, 6)},
                 {"layer_present_fraction", Significant(f.layer_present_fraction, 6)},
                 {"realtime_factor", Significant(entry.realtime_factor, 6)},
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
