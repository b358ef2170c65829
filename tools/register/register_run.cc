#include "tools/register/register_run.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "io/calibration.h"
#include "io/elapsed_time.h"
#include "io/registration_file.h"
#include "io/scene.h"
#include "sim/error.h"
#include "stages/register/bead_detection.h"
#include "stages/register/fiducial_motion.h"
#include "tools/json_text.h"
#include "tools/register/truth_tracks.h"
#include "tools/register/video_fiducials.h"

namespace dg::tools {
namespace {

using Json = nlohmann::ordered_json;

// One eye's reprojection figures, each key ending in _left or _right.
void AddStats(const std::string& eye, const io::ReprojectionStats& s, Json* json) {
  (*json)["residual_px_" + eye] = Significant(s.mean_px, 6);
  (*json)["residual_mm_" + eye] = Significant(s.mean_mm, 6);
  (*json)["residual_max_px_" + eye] = Significant(s.max_px, 6);
  (*json)["residual_rms_px_" + eye] = Significant(s.rms_px, 6);
  (*json)["residual_max_mm_" + eye] = Significant(s.max_mm, 6);
  (*json)["residual_rms_mm_" + eye] = Significant(s.rms_mm, 6);
  (*json)["observations_" + eye] = s.observations;
  (*json)["outliers_" + eye] = s.outliers;
}

}  // namespace

double RotationAngleDeg(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b) {
  const Eigen::Matrix3d R = a.topLeftCorner<3, 3>().transpose() * b.topLeftCorner<3, 3>();
  return Eigen::AngleAxisd(R).angle() * 180.0 / M_PI;
}

RegistrationError CompareWithTruth(const io::Registration& registration, const Eigen::Matrix4d& T_C_S_truth,
                                   double phase_shift_truth_s) {
  RegistrationError error;
  error.rotation_deg = RotationAngleDeg(registration.T_C_S, T_C_S_truth);
  error.translation_mm = 1e3 * (registration.T_C_S.topRightCorner<3, 1>() - T_C_S_truth.topRightCorner<3, 1>()).norm();
  const double P = registration.period_s;
  double d = registration.phase_shift_s - phase_shift_truth_s;
  d -= P * std::round(d / P);
  error.phase_shift_ms = 1e3 * d;
  return error;
}

RegisterRunSummary RunRegister(const RegisterRunOptions& given) {
  const io::Scene scene = io::ReadScene(given.scene);
  // What the command line leaves out, the scene's registration block says, as it does for `run`.
  const io::Scene::Registration window = scene.registration.value_or(io::Scene::Registration{});
  RegisterRunOptions options = given;
  if (options.cycles == 0) options.cycles = window.cycles;
  if (options.fiducials_uv.empty()) options.fiducials_uv = window.fiducials_uv;
  const std::string cycles_from = given.cycles == 0 ? "the scene's registration.cycles" : "--cycles";
  if (!(options.cycles >= 1)) {
    throw Error(cycles_from + " must be at least 1, got " + std::to_string(options.cycles), scene.path,
                "register over whole cycles");
  }
  if (!scene.preoperative) {
    throw Error("the scene has no preoperative data (period, phases, scan)", scene.path,
                "add a preoperative: block with period_s, phases, motion and ct");
  }
  const io::Scene::Preoperative& scan = *scene.preoperative;
  RegisterRunSummary summary;

  stages::FiducialMotion motion;
  if (options.ct_beads) {
    if (static_cast<int>(scan.ct_volumes.size()) != scan.phases) {
      throw Error("the scene names " + std::to_string(scan.ct_volumes.size()) + " CT volumes for " +
                      std::to_string(scan.phases) + " phases",
                  scene.path, "give preoperative.ct with one volume per phase");
    }
    motion = stages::DetectBeadMotion(scan.ct_volumes, {});
    summary.fiducials_from = "beads in the CT volumes";
    if (options.fiducials_uv.empty()) {
      // The beads' numbering is the detection's: only the user can say which marker in the video is which.
      std::string beads;
      for (int i = 0; i < motion.num_fiducials(); ++i) {
        char bead[96];
        const Eigen::Vector3d x = 1e3 * motion.positions_S_m[0].col(i);
        std::snprintf(bead, sizeof bead, "%s%d: (%.1f, %.1f, %.1f) mm", i ? ", " : "", i, x.x(), x.y(), x.z());
        beads += bead;
      }
      throw Error("found " + std::to_string(motion.num_fiducials()) + " beads in the CT (phase 0, scan frame: " + beads +
                      ") but not which marker in the video each one is",
                  scene.path, "give --fiducials-uv FILE with each bead's pixel in the first left frame, in this order");
    }
  } else {
    motion = stages::ReadFiducialMotion(scan.motion);
    summary.fiducials_from = scan.motion;
  }
  if (motion.num_phases() != scan.phases) {
    throw Error("the scan has " + std::to_string(motion.num_phases()) + " phases of fiducials but the scene says " +
                    std::to_string(scan.phases),
                scene.path, "make preoperative.phases match the scan");
  }
  summary.fiducials = motion.num_fiducials();

  std::vector<Eigen::Vector2d> first_uv;
  if (!options.fiducials_uv.empty()) {
    first_uv = io::ReadFiducialPixels(options.fiducials_uv);
    summary.starts_from = options.fiducials_uv;
  } else if (!scene.truth.empty()) {
    const RegistrationTruth truth = ReadRegistrationTruth(scene.truth);
    for (const stages::FiducialSighting& s : truth.tracks.frames.front()) first_uv.push_back(s.uv_left_px);
    summary.starts_from = "the truth's first frame (" + scene.truth + ")";
  } else {
    throw Error("the fiducials' first-frame pixels are not known", scene.path,
                "give --fiducials-uv FILE with one u,v line per fiducial (first left frame, the scan's order)");
  }
  if (static_cast<int>(first_uv.size()) != motion.num_fiducials()) {
    throw Error(std::to_string(first_uv.size()) + " first-frame pixels for " + std::to_string(motion.num_fiducials()) +
                    " scan fiducials",
                summary.starts_from, "give one pixel per scan fiducial, in the scan's order");
  }

  auto start = std::chrono::steady_clock::now();
  if (options.progress) std::fprintf(stderr, "register: tracking %zu fiducials over %.2f cycles\n", first_uv.size(), options.cycles);
  io::StereoCalibration calibration;
  const stages::FiducialTracks tracks =
      TrackFiducialsInVideo(scene, first_uv, options.cycles * scan.period_s, &calibration);
  summary.track_ms = io::MsSince(start);
  summary.frames = static_cast<int>(tracks.t_s.size());
  const double frame_s = summary.frames > 1 ? (tracks.t_s.back() - tracks.t_s.front()) / (summary.frames - 1) : 0;
  const double held_cycles = summary.frames > 1 ? (tracks.t_s.back() - tracks.t_s.front() + frame_s) / scan.period_s : 0;
  if (held_cycles < options.cycles - 1e-6) {
    throw Error("the video holds " + std::to_string(held_cycles) + " cycles but " + cycles_from + " asks for " +
                    std::to_string(options.cycles),
                scene.path, "register over fewer cycles, or record longer");
  }

  start = std::chrono::steady_clock::now();
  summary.result = stages::RegisterScanToVideo(motion, calibration, scan.period_s,
                                               tracks, options.solver);
  summary.solve_ms = io::MsSince(start);
  if (!scene.truth.empty()) {
    const RegistrationTruth truth = ReadRegistrationTruth(scene.truth);
    summary.error = CompareWithTruth(summary.result.registration, truth.T_C_S, truth.phase_shift_s);
  }
  return summary;
}

std::string RegisterReport(const RegisterRunSummary& summary) {
  const io::Registration& r = summary.result.registration;
  std::string text;
  char line[256];
  std::snprintf(line, sizeof line, "fiducials: %d from %s; tracked from %s\nwindow: %d frames, %.2f cycles\n",
                summary.fiducials, summary.fiducials_from.c_str(), summary.starts_from.c_str(), summary.frames,
                r.cycles);
  text += line;
  text += "T_C_S (metres):\n";
  for (int row = 0; row < 4; ++row) {
    std::snprintf(line, sizeof line, "  %10.6f %10.6f %10.6f %10.6f\n", r.T_C_S(row, 0), r.T_C_S(row, 1),
                  r.T_C_S(row, 2), r.T_C_S(row, 3));
    text += line;
  }
  std::snprintf(line, sizeof line, "phase shift: %.2f ms (period %.2f ms)\n", 1e3 * r.phase_shift_s, 1e3 * r.period_s);
  text += line;
  for (const auto& [eye, s] : {std::pair{"left", &r.left}, std::pair{"right", &r.right}}) {
    std::snprintf(line, sizeof line,
                  "residual %-5s: mean %.3f px / %.3f mm, RMS %.3f px / %.3f mm, max %.3f px / %.3f mm "
                  "(%d observations, %d outliers)\n",
                  eye, s->mean_px, s->mean_mm, s->rms_px, s->rms_mm, s->max_px, s->max_mm, s->observations,
                  s->outliers);
    text += line;
  }
  const stages::FiducialAssignment& a = summary.result.assignment;
  const double worst_departure_px =
      a.track_departure_px.empty() ? 0 : *std::max_element(a.track_departure_px.begin(), a.track_departure_px.end());
  text += fmt::format(
      "self-check: the markers' mean positions fit the scan's to {:.2f} px, the farthest track {:.2f} px from the "
      "pose the others fit ({}); the next distinct minimum costs {}\n",
      a.rms_px, worst_departure_px,
      a.verdict == stages::FiducialAssignment::Verdict::kReassigned
          ? "reassigned: " + stages::DescribeDepartures(a.scan_of_track)
          : std::string("in the order given"),
      std::isfinite(summary.result.runner_up_cost_ratio)
          ? fmt::format("{:.3g}x the best's", summary.result.runner_up_cost_ratio)
          : std::string("nothing (every candidate reached the best)"));
  std::snprintf(line, sizeof line, "uncertainty (1 sigma): rotation %.4f deg, translation %.4f mm, phase shift %.3f ms\n",
                r.rotation_sigma_deg(), r.translation_sigma_mm(), r.phase_shift_sigma_ms());
  text += line;
  if (summary.error) {
    std::snprintf(line, sizeof line, "vs truth: rotation %.4f deg, translation %.4f mm, phase shift %+.2f ms\n",
                  summary.error->rotation_deg, summary.error->translation_mm, summary.error->phase_shift_ms);
    text += line;
  }
  std::snprintf(line, sizeof line, "time: tracking %.0f ms, registration %.0f ms\n", summary.track_ms, summary.solve_ms);
  return text + line;
}

void WriteRegisterJson(const std::string& path, const RegisterRunSummary& summary) {
  const io::Registration& r = summary.result.registration;
  Json json;
  Json matrix = Json::array();  // row-major, every digit
  for (int k = 0; k < 16; ++k) matrix.push_back(r.T_C_S(k / 4, k % 4));
  json["T_C_S"] = matrix;
  json["phase_shift_s"] = r.phase_shift_s;
  json["period_s"] = r.period_s;
  json["cycles"] = Significant(r.cycles, 6);
  json["frames"] = summary.frames;
  json["fiducials"] = summary.fiducials;
  AddStats("left", r.left, &json);
  AddStats("right", r.right, &json);
  json["rotation_sigma_deg"] = Significant(r.rotation_sigma_deg(), 6);
  json["translation_sigma_mm"] = Significant(r.translation_sigma_mm(), 6);
  json["phase_shift_sigma_ms"] = Significant(r.phase_shift_sigma_ms(), 6);
  json["track_ms"] = Significant(summary.track_ms, 4);
  json["solve_ms"] = Significant(summary.solve_ms, 4);
  json["fiducials_from"] = summary.fiducials_from;
  json["markers_fit_px"] = Significant(summary.result.assignment.rms_px, 6);
  json["markers_reassigned"] = summary.result.assignment.verdict == stages::FiducialAssignment::Verdict::kReassigned;
  json["runner_up_cost_ratio"] = Significant(summary.result.runner_up_cost_ratio, 6);  // infinite (null): no distinct runner-up
  if (summary.error) {
    json["error_rotation_deg"] = Significant(summary.error->rotation_deg, 6);
    json["error_translation_mm"] = Significant(summary.error->translation_mm, 6);
    json["error_phase_shift_ms"] = Significant(summary.error->phase_shift_ms, 6);
  }
  std::ofstream out(path);
  if (!(out << JsonText(json))) {
    throw Error("cannot write the registration JSON", path, "check the directory exists and is writable");
  }
}

}  // namespace dg::tools
