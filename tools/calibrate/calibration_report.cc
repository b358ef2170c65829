#include "tools/calibrate/calibration_report.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "sim/error.h"
#include "tools/json_text.h"

namespace dg::tools::calibrate {
namespace {

std::string Format(const char* format, double a, double b = 0, double c = 0, double d = 0) {
  char line[256];
  std::snprintf(line, sizeof line, format, a, b, c, d);
  return line;
}

std::vector<double> Rounded(const std::vector<double>& values) {
  std::vector<double> rounded;
  for (double value : values) rounded.push_back(Decimals(value, 4));
  return rounded;
}

// Each used view's files and errors, its corners row by row.
nlohmann::ordered_json ViewsJson(const StereoCalibrationReport& report) {
  nlohmann::ordered_json views = nlohmann::ordered_json::array();
  for (size_t v = 0; v < report.views.size(); ++v) {
    const StereoCalibrationReport::ViewErrors& errors = report.views[v];
    views.push_back({{"left", report.used[v].left_path},
                     {"right", report.used[v].right_path},
                     {"rms_left_px", Decimals(errors.rms_left_px, 6)},
                     {"rms_right_px", Decimals(errors.rms_right_px, 6)},
                     {"rms_stereo_left_px", Decimals(errors.stereo_left_px, 6)},
                     {"rms_stereo_right_px", Decimals(errors.stereo_right_px, 6)},
                     {"corner_errors_left_px", Rounded(errors.corner_left_px)},
                     {"corner_errors_right_px", Rounded(errors.corner_right_px)}});
  }
  return views;
}

}  // namespace

std::string DescribeReport(const StereoCalibrationReport& report) {
  const io::StereoCalibration& calibration = report.calibration;
  std::ostringstream text;
  text << "views used: " << report.used.size() << ", rejected: " << report.rejected.size() << "\n";
  for (const std::string& rejected : report.rejected) text << "  rejected " << rejected << "\n";
  text << Format("RMS reprojection error: left %.3f px, right %.3f px, stereo %.3f px\n", report.rms_left_px,
                 report.rms_right_px, report.rms_stereo_px);
  text << Format("mean epipolar error after rectification: %.3f px\n", report.epipolar_error_px);
  for (const auto& [name, camera] : {std::pair{"left", &calibration.left}, std::pair{"right", &calibration.right}}) {
    text << name
         << Format(": f = (%.2f, %.2f) px, c = (%.2f, %.2f) px\n", camera->fx(), camera->fy(), camera->cx(),
                   camera->cy());
  }
  text << Format("baseline: %.3f mm (with the intrinsics free: %.3f mm)\n", 1e3 * calibration.T_m.norm(),
                 1e3 * report.free_intrinsics_baseline_m);
  double worst_rms = 0;
  size_t worst = 0;
  for (size_t v = 0; v < report.views.size(); ++v) {
    const double rms = std::max(report.views[v].rms_left_px, report.views[v].rms_right_px);
    if (rms > worst_rms) worst_rms = rms, worst = v;
  }
  if (!report.views.empty()) {
    text << "worst view: " << report.used[worst].left_path << ", " << report.used[worst].right_path
         << Format(" (RMS %.3f px left, %.3f px right)\n", report.views[worst].rms_left_px,
                   report.views[worst].rms_right_px);
  }
  for (const std::string& warning : report.warnings) text << "warning: " << warning << "\n";
  return text.str();
}

void WriteReportJson(const std::string& path, const StereoCalibrationReport& report) {
  std::ofstream file(path);
  if (!file) throw Error("cannot write the JSON report", path, "check that the directory exists and is writable");
  const nlohmann::ordered_json json = {{"rms_left_px", Decimals(report.rms_left_px, 6)},
                                      {"rms_right_px", Decimals(report.rms_right_px, 6)},
                                      {"rms_stereo_px", Decimals(report.rms_stereo_px, 6)},
                                      {"epipolar_error_px", Decimals(report.epipolar_error_px, 6)},
                                      {"baseline_m", Decimals(report.calibration.T_m.norm(), 9)},
                                      {"baseline_free_intrinsics_m", Decimals(report.free_intrinsics_baseline_m, 9)},
                                      {"views_used", report.used.size()},
                                      {"views_rejected", report.rejected.size()},
                                      {"rejected", report.rejected},
                                      {"views", ViewsJson(report)},
                                      {"warnings", report.warnings}};
  file << JsonText(json);
  if (!file) throw Error("cannot write the JSON report", path, "check the free space");
}

}  // namespace dg::tools::calibrate
