// `dynaguide eval protocol` on the tiny phantom: the three modes run end to
// end under both policies, and the report's Table 1, the simulated state's
// and the overlay's as shown, is recomputed here from the run logs through
// the plain HDF5 C API.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <catch2/catch.hpp>

#include "io/h5_file.h"
#include "io/registration_file.h"
#include "io/scene.h"
#include "pipeline/run_scene.h"
#include "tests/support/h5_plain.h"
#include "tests/support/tiny_phantom.h"
#include "tests/support/window_errors.h"
#include "tools/eval/protocol.h"
#include "tools/eval/run_errors.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;
using namespace dg::testing::h5_plain;

// The rows of a run log's window: those whose frame lies within `window`
// frames of its first simulated one (a realtime run may have dropped some).
int RowsInWindow(hid_t file, int window) {
  const std::vector<double> frame = Doubles(file, "/errors/frame");
  return static_cast<int>(std::count_if(frame.begin(), frame.end(),
                                        [&](double f) { return f < frame.front() + window; }));
}

// The frames a run log's /errors spans, first to last simulated.
int FrameSpan(const std::string& log) {
  const hid_t file = H5Fopen(log.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  const std::vector<double> frame = Doubles(file, "/errors/frame");
  H5Fclose(file);
  REQUIRE(!frame.empty());
  return static_cast<int>(frame.back() - frame.front()) + 1;
}

// Table 1's row of one run log, over the rows of its window of `window` simulated frames.
testing::WindowErrors RecomputeRow(const std::string& log, int window) {
  const hid_t file = H5Fopen(log.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  const testing::WindowErrors row = testing::ReadWindowErrors(file, RowsInWindow(file, window));
  H5Fclose(file);
  return row;
}

// The overlay as shown over a run log's window, from its own shown_* columns
// (NaN where a frame was composed without the layer): the surface pooled by
// point count, the internal figures over rows of equally many points.
struct ShownErrors {
  int surface_rows = 0, internal_rows = 0;
  double surface_avg = 0, surface_max = 0, surface_rms = 0;
  double internal_avg = 0, internal_max = 0, internal_rms = 0;
};

ShownErrors RecomputeShown(const std::string& log, int window) {
  const hid_t file = H5Fopen(log.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  const int rows = RowsInWindow(file, window);
  const std::vector<double> n = Doubles(file, "/errors/surface_points");
  const std::vector<double> surface_mean = Doubles(file, "/errors/shown_surface_mean_mm");
  const std::vector<double> surface_rms = Doubles(file, "/errors/shown_surface_rms_mm");
  const std::vector<double> surface_max = Doubles(file, "/errors/shown_surface_max_mm");
  const std::vector<double> internal_mean = Doubles(file, "/errors/shown_internal_mean_mm");
  const std::vector<double> internal_rms = Doubles(file, "/errors/shown_internal_rms_mm");
  const std::vector<double> internal_max = Doubles(file, "/errors/shown_internal_max_mm");
  H5Fclose(file);
  ShownErrors shown;
  double points = 0, surface_sum = 0, surface_squares = 0, internal_squares = 0;
  for (int k = 0; k < rows; ++k) {
    if (!std::isnan(surface_mean[k])) {
      ++shown.surface_rows;
      points += n[k];
      surface_sum += n[k] * surface_mean[k];
      surface_squares += n[k] * surface_rms[k] * surface_rms[k];
      shown.surface_max = std::max(shown.surface_max, surface_max[k]);
    }
    if (!std::isnan(internal_mean[k])) {
      ++shown.internal_rows;
      shown.internal_avg += internal_mean[k];
      internal_squares += internal_rms[k] * internal_rms[k];
      shown.internal_max = std::max(shown.internal_max, internal_max[k]);
    }
  }
  REQUIRE(shown.surface_rows > 0);
  REQUIRE(shown.internal_rows > 0);
  shown.surface_avg = surface_sum / points;
  shown.surface_rms = std::sqrt(surface_squares / points);
  shown.internal_avg /= shown.internal_rows;
  shown.internal_rms = std::sqrt(internal_squares / shown.internal_rows);
  return shown;
}

// The lines of a text file.
std::vector<std::string> Lines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// table1.csv's row of a mode and policy: the figures after those two columns.
std::vector<double> CsvRow(const std::string& csv_path, const std::string& mode, const std::string& policy) {
  const std::string key = mode + "," + policy + ",";
  std::ifstream csv(csv_path);
  for (std::string line; std::getline(csv, line);) {
    if (line.rfind(key, 0) != 0) continue;
    std::vector<double> values;
    std::stringstream fields(line.substr(key.size()));
    for (std::string field; std::getline(fields, field, ',');) values.push_back(std::stod(field));
    return values;
  }
  FAIL("no row for " << mode << ", " << policy << " in " << csv_path);
  return {};
}

// The run directory `dynaguide eval protocol` gives a mode and policy.
std::string RunDir(const std::string& mode, const std::string& policy) {
  return policy == "offline" ? mode : mode + "-" + policy;
}

}  // namespace

TEST_CASE("eval protocol: the tiny phantom in three modes and two policies, its tables recomputed from the logs",
          "[tools][integration]") {
  ProtocolOptions options;
  options.scene = dg::testing::TinyPhantomDir() + "/scene.yaml";
  options.out_dir = dg::testing::TinyPhantomDir() + "/eval";
  options.threads = 2;
  options.progress = false;
  // At 160x120 the registration from the video is about 0.8 mm off at the
  // fiducials (a pixel of disparity is millimetres of depth there), more than
  // the modes differ by, and the surface mode partly cancels it (its targets
  // go through the registration both ways): the modes are compared with the
  // truth's registration. The default phantom's protocol registers from the video.
  options.truth_registration = true;
  const ProtocolResult result = RunProtocol(options);
  WriteProtocolReport(result, options.out_dir);
  REQUIRE(result.runs.size() == 6);
  REQUIRE(result.entries.size() == 6);
  REQUIRE(result.runs.front().registration_given);
  // The tiny video (1 s, 30 frames) is simulated from its first frame: 1.5
  // cycles, short of three and said so; as far as every run reaches, should
  // a realtime run have dropped its last frames.
  const std::string runs_dir = options.out_dir + "/runs/" + result.scenes.front() + "/";
  int reach = 30;
  for (sim::SimulationMode mode : ProtocolModes()) {
    const std::string log = runs_dir + RunDir(sim::ToString(mode), "offline") + "/run.h5";
    REQUIRE(FrameSpan(log) == 30);
    reach = std::min(reach, FrameSpan(runs_dir + RunDir(sim::ToString(mode), "realtime") + "/run.h5"));
  }
  REQUIRE(result.window_frames == reach);
  REQUIRE(result.window_cycles == Approx(reach / 20.0).epsilon(0.01));

  for (const ProtocolEntry& entry : result.entries) {
    const std::string mode = sim::ToString(entry.mode);
    INFO(mode << ", " << entry.policy);
    REQUIRE(entry.ran);
    const std::string log = runs_dir + RunDir(mode, entry.policy) + "/run.h5";
    const testing::WindowErrors row = RecomputeRow(log, result.window_frames);
    const ErrorFigures& figures = entry.figures;
    CHECK(figures.surface_avg_mm == Approx(row.surface_avg).epsilon(1e-9));
    CHECK(figures.surface_max_mm == Approx(row.surface_max).epsilon(1e-9));
    CHECK(figures.surface_rms_mm == Approx(row.surface_rms).epsilon(1e-9));
    CHECK(figures.internal_avg_mm == Approx(row.internal_avg).epsilon(1e-9));
    CHECK(figures.internal_max_mm == Approx(row.internal_max).epsilon(1e-9));
    CHECK(figures.internal_rms_mm == Approx(row.internal_rms).epsilon(1e-9));
    CHECK(figures.typical_points == row.typical_points);
    CHECK(figures.typical_avg_mm == Approx(row.typical_avg).epsilon(1e-9));
    CHECK(figures.typical_max_mm == Approx(row.typical_max).epsilon(1e-9));
    CHECK(figures.typical_rms_mm == Approx(row.typical_rms).epsilon(1e-9));
    // The overlay as shown, as the log's own shown_* columns give it.
    const ShownErrors shown = RecomputeShown(log, result.window_frames);
    CHECK(figures.shown_surface_avg_mm == Approx(shown.surface_avg).epsilon(1e-12));
    CHECK(figures.shown_surface_max_mm == Approx(shown.surface_max).epsilon(1e-12));
    CHECK(figures.shown_surface_rms_mm == Approx(shown.surface_rms).epsilon(1e-12));
    CHECK(figures.shown_internal_avg_mm == Approx(shown.internal_avg).epsilon(1e-12));
    CHECK(figures.shown_internal_max_mm == Approx(shown.internal_max).epsilon(1e-12));
    CHECK(figures.shown_internal_rms_mm == Approx(shown.internal_rms).epsilon(1e-12));
    CHECK(figures.shown_frames <= std::min(shown.surface_rows, shown.internal_rows));
    CHECK(figures.layer_present_fraction == Approx(double(figures.shown_frames) / figures.frames));
    // Offline every simulated frame is composed with layers drawn from its own
    // state: what the surgeon sees is the simulated state, to the last bits.
    if (entry.policy == "offline") {
      CHECK(figures.layer_present_fraction == 1.0);
      CHECK(figures.shown_frames == figures.frames);
      CHECK(figures.shown_surface_avg_mm == Approx(figures.surface_avg_mm).margin(1e-12));
      CHECK(figures.shown_surface_max_mm == Approx(figures.surface_max_mm).margin(1e-12));
      CHECK(figures.shown_surface_rms_mm == Approx(figures.surface_rms_mm).margin(1e-12));
      CHECK(figures.shown_internal_avg_mm == Approx(figures.internal_avg_mm).margin(1e-12));
      CHECK(figures.shown_internal_max_mm == Approx(figures.internal_max_mm).margin(1e-12));
      CHECK(figures.shown_internal_rms_mm == Approx(figures.internal_rms_mm).margin(1e-12));
    }
    // The CSV holds the same figures (6 decimals), the shown ones after the typical feature's.
    const std::vector<double> csv = CsvRow(options.out_dir + "/table1.csv", mode, entry.policy);
    REQUIRE(csv.size() == 19);
    CHECK(csv[0] == Approx(row.surface_avg).margin(1e-6));
    CHECK(csv[4] == Approx(row.internal_max).margin(1e-6));
    CHECK(csv[11] == figures.shown_frames);
    CHECK(csv[12] == Approx(shown.surface_avg).margin(1e-6));
    CHECK(csv[17] == Approx(shown.internal_rms).margin(1e-6));
    CHECK(csv[18] == Approx(figures.layer_present_fraction).margin(1e-4));
  }
  // The paper's finding (Table 1, right): internal forces make the interior
  // more accurate than the tracked surface alone.
  const auto internal_avg = [&](sim::SimulationMode mode) {
    return result.Find("offline", mode)->figures.internal_avg_mm;
  };
  CHECK(internal_avg(sim::SimulationMode::kCombined) <= internal_avg(sim::SimulationMode::kSurface));
  CHECK(internal_avg(sim::SimulationMode::kVolume) <= internal_avg(sim::SimulationMode::kSurface));
  for (const char* file : {"/report.md", "/table2.csv", "/fig2_surface.png", "/fig2_internal.png"}) {
    CHECK(fs::file_size(options.out_dir + file) > 100);
  }

  SECTION("report DIR merges the logs it finds into the same tables") {
    const ProtocolResult merged = ReadProtocolLogs(options.out_dir + "/runs", options.cycles);
    REQUIRE(merged.runs.size() == 6);
    for (const std::string policy : {"offline", "realtime"}) {
      const ErrorFigures& merged_volume = merged.Find(policy, sim::SimulationMode::kVolume)->figures;
      const ErrorFigures& volume = result.Find(policy, sim::SimulationMode::kVolume)->figures;
      CHECK(merged_volume.internal_avg_mm == volume.internal_avg_mm);
      CHECK(merged_volume.shown_internal_avg_mm == volume.shown_internal_avg_mm);
    }
  }

  SECTION("--emit-jobs lists one run per scene, mode and policy instead of running") {
    ProtocolOptions jobs = options;
    jobs.emit_jobs = options.out_dir + "/jobs.txt";
    RunProtocol(jobs);
    int lines = 0, realtime = 0;
    for (const std::string& line : Lines(jobs.emit_jobs)) {
      ++lines;
      CHECK(line.rfind("dynaguide run ", 0) == 0);
      const bool is_realtime = line.find(" --policy realtime") != std::string::npos;
      realtime += is_realtime;
      CHECK((line.find("-realtime --no-video") != std::string::npos) == is_realtime);
    }
    CHECK(lines == 6);  // one scene, three modes, two policies
    CHECK(realtime == 3);
  }
}

// A policy other than offline and realtime is refused before anything runs.
TEST_CASE("eval protocol: an unknown policy is refused", "[tools][unit]") {
  ProtocolOptions options;
  options.policies = {"offline", "fast"};
  options.progress = false;
  REQUIRE_THROWS_WITH(RunProtocol(options), Catch::Contains("unknown policy 'fast'") && Catch::Contains("--policy"));
  options.policies.clear();
  REQUIRE_THROWS_WITH(RunProtocol(options), Catch::Contains("no policy to run"));
}

// `dynaguide report DIR` on a folder holding a single run (combined mode, the
// tiny scene's): the modes it did not run are absent from the CSV files and
// the JSON, and say "not run" in report.md, never a row of zeros; the mode
// it ran keeps its figures, recomputed here from the log.
TEST_CASE("eval protocol: a report of one run has no figures for the modes it did not run", "[tools][integration]") {
  // The truth's registration, as the protocol test gives it: the tables, not the registration, are under test.
  const std::string dir = dg::testing::TinyPhantomDir();
  const io::H5Reader truth(dir + "/truth.h5");
  io::Registration registration;
  registration.T_C_S = truth.ReadMatrix("/T_C_S");
  registration.phase_shift_s = truth.ReadScalar("/phase_shift_s");
  registration.period_s = truth.ReadScalar("/period_s");
  io::WriteRegistrationYaml(dir + "/single_registration.yaml", registration);
  std::string text = io::ReadScene(dir + "/scene.yaml").text;
  const size_t at = text.find("registration:\n  cycles: 1");
  REQUIRE(at != std::string::npos);
  text.replace(at, 25, "registration:\n  file: single_registration.yaml");
  std::ofstream(dir + "/scene_single.yaml") << text;
  pipeline::RunOptions run;
  run.scene = dir + "/scene_single.yaml";
  run.out_dir = dg::testing::TinyPhantomDir() + "/single/run";
  run.threads = 2;
  run.video = false;
  run.progress = false;
  pipeline::RunScene(run);
  const std::string out = dg::testing::TinyPhantomDir() + "/single_report";
  const ProtocolResult result = ReadProtocolLogs(dg::testing::TinyPhantomDir() + "/single", 3);
  WriteProtocolReport(result, out);
  WriteProtocolJson(result, out + "/protocol.json");
  // One policy (the run's, offline): no realtime entries at all.
  REQUIRE(result.entries.size() == 3);
  for (const ProtocolEntry& entry : result.entries) {
    CHECK(entry.policy == "offline");
    CHECK(entry.ran == (entry.mode == sim::SimulationMode::kCombined));
  }

  const std::vector<std::string> table1 = Lines(out + "/table1.csv");
  REQUIRE(table1.size() == 2);  // the header and the combined mode's row
  CHECK(table1[1].rfind("combined,offline,", 0) == 0);
  const testing::WindowErrors row = RecomputeRow(run.out_dir + "/run.h5", result.window_frames);
  const std::vector<double> combined = CsvRow(out + "/table1.csv", "combined", "offline");
  CHECK(combined[0] == Approx(row.surface_avg).margin(1e-6));
  CHECK(combined[3] == Approx(row.internal_avg).margin(1e-6));
  CHECK(row.surface_avg > 0);
  CHECK(Lines(out + "/table2.csv").size() == 1);  // Table 2 is the volume mode's: the header alone

  std::ifstream md_file(out + "/report.md");
  const std::string md((std::istreambuf_iterator<char>(md_file)), std::istreambuf_iterator<char>());
  CHECK_THAT(md, Catch::Contains("| surface | offline | not run |") &&
                     Catch::Contains("| volume | offline | not run |") &&
                     Catch::Contains("Not run: Table 2 is the volume mode's"));
  CHECK_THAT(md, !Catch::Contains("| surface | offline | 0.00") && !Catch::Contains("| realtime |"));

  std::ifstream json_file(out + "/protocol.json");
  const std::string json((std::istreambuf_iterator<char>(json_file)), std::istreambuf_iterator<char>());
  CHECK_THAT(json, Catch::Contains("\"mode\": \"combined\",\n      \"policy\": \"offline\""));
  CHECK_THAT(json, !Catch::Contains("\"mode\": \"surface\"") && !Catch::Contains("\"mode\": \"volume\""));
  fs::remove_all(out);
  fs::remove_all(dg::testing::TinyPhantomDir() + "/single");
}

// A run log written before the overlay as composed was logged: no layer ages,
// no shown_* columns, no policy attribute. It reads as an offline run whose
// state figures are unchanged and whose overlay as shown is unknown (NaN, n/a
// in report.md, null in the JSON), and the report is written all the same.
TEST_CASE("eval protocol: a log without the overlay's columns has no shown figures", "[tools][integration]") {
  pipeline::RunOptions run;
  run.scene = dg::testing::TinyPhantomDir() + "/scene.yaml";
  run.out_dir = dg::testing::TinyPhantomDir() + "/old_log/new";
  run.threads = 2;
  run.video = false;
  run.progress = false;
  pipeline::RunScene(run);
  const std::string log = run.out_dir + "/run.h5";
  const std::string old_dir = dg::testing::TinyPhantomDir() + "/old_log/old";
  fs::create_directories(old_dir);
  fs::copy_file(log, old_dir + "/run.h5");
  const hid_t file = H5Fopen((old_dir + "/run.h5").c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  REQUIRE(file >= 0);
  for (const char* column :
       {"surface_layer_age_frames", "internal_layer_age_frames", "shown_surface_mean_px", "shown_surface_rms_px",
        "shown_surface_max_px", "shown_surface_mean_mm", "shown_surface_rms_mm", "shown_surface_max_mm",
        "shown_internal_mean_mm", "shown_internal_rms_mm", "shown_internal_max_mm"}) {
    REQUIRE(H5Ldelete(file, (std::string("/errors/") + column).c_str(), H5P_DEFAULT) >= 0);
  }
  REQUIRE(H5Adelete(file, "policy") >= 0);
  H5Fclose(file);

  const RunErrors current = ReadRunErrors(log);
  const RunErrors old = ReadRunErrors(old_dir + "/run.h5");
  CHECK(current.policy == "offline");
  CHECK(current.surface_layer_age_frames.size() == current.frame.size());
  CHECK(old.policy == "offline");
  CHECK(old.surface_layer_age_frames.empty());
  CHECK(old.internal_layer_age_frames.empty());
  const ErrorFigures now = Figures({&current}, -1);
  const ErrorFigures before = Figures({&old}, -1);
  CHECK(now.layer_present_fraction == 1.0);
  CHECK(before.surface_avg_mm == now.surface_avg_mm);
  CHECK(before.internal_rms_mm == now.internal_rms_mm);
  CHECK(before.shown_frames == 0);
  for (double shown : {before.shown_surface_avg_mm, before.shown_surface_max_mm, before.shown_surface_rms_mm,
                       before.shown_internal_avg_mm, before.shown_internal_max_mm, before.shown_internal_rms_mm,
                       before.layer_present_fraction}) {
    CHECK(std::isnan(shown));
  }

  const ProtocolResult result = ReadProtocolLogs(old_dir, 3);
  const std::string out = dg::testing::TinyPhantomDir() + "/old_log/report";
  const std::string md = WriteProtocolReport(result, out);
  WriteProtocolJson(result, out + "/protocol.json");
  const ProtocolEntry* combined = result.Find("offline", sim::SimulationMode::kCombined);
  REQUIRE(combined);
  REQUIRE(combined->ran);
  CHECK(std::isnan(combined->figures.shown_surface_avg_mm));
  CHECK_THAT(md, Catch::Contains("| n/a | n/a | n/a | n/a | n/a | n/a | n/a |"));
  std::ifstream json_file(out + "/protocol.json");
  const std::string json((std::istreambuf_iterator<char>(json_file)), std::istreambuf_iterator<char>());
  CHECK_THAT(json, Catch::Contains("\"shown_surface_avg_mm\": null") &&
                       Catch::Contains("\"layer_present_fraction\": null"));
  fs::remove_all(dg::testing::TinyPhantomDir() + "/old_log");
}

}  // namespace dg::tools
