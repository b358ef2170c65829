#include "io/registration_file.h"

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include <Eigen/Dense>

#include "io/h5_file.h"
#include "io/input_file.h"
#include "io/yaml_map.h"
#include "sim/error.h"

namespace dg::io {
namespace {

constexpr const char* kStatsKeys[] = {"observations", "outliers", "mean_px", "max_px",
                                      "rms_px",       "mean_mm",  "max_mm",  "rms_mm"};

std::array<double, 8> StatsValues(const ReprojectionStats& s) {
  return {double(s.observations), double(s.outliers), s.mean_px, s.max_px, s.rms_px, s.mean_mm, s.max_mm, s.rms_mm};
}

std::string MatrixRows(const Eigen::MatrixXd& m) {
  std::string text;
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    text += "  - [";
    for (Eigen::Index c = 0; c < m.cols(); ++c) {
      char value[32];
      std::snprintf(value, sizeof value, "%s%.17g", c ? ", " : "", m(r, c));
      text += value;
    }
    text += "]\n";
  }
  return text;
}

Eigen::MatrixXd ReadMatrix(const YamlMap& map, const std::string& key, int rows, int cols) {
  const YAML::Node node = map.Node(key);
  const std::string fix = "give " + std::to_string(rows) + " rows of " + std::to_string(cols) + " numbers";
  if (!node.IsSequence() || static_cast<int>(node.size()) != rows) {
    throw Error("'" + key + "' must be a list of " + std::to_string(rows) + " rows", map.Where(key), fix);
  }
  Eigen::MatrixXd m(rows, cols);
  for (int r = 0; r < rows; ++r) {
    if (!node[r].IsSequence() || static_cast<int>(node[r].size()) != cols) {
      throw Error("row " + std::to_string(r) + " of '" + key + "' must hold " + std::to_string(cols) + " numbers",
                  map.Where(key), fix);
    }
    for (int c = 0; c < cols; ++c) {
      try {
        m(r, c) = node[r][c].as<double>();
      } catch (const YAML::Exception&) {
        throw Error("'" + key + "' row " + std::to_string(r) + " column " + std::to_string(c) + " is not a number",
                    map.Where(key), fix);
      }
    }
  }
  return m;
}

ReprojectionStats ReadStats(const YamlMap& map) {
  ReprojectionStats s;
  s.observations = map.Integer("observations", -1);
  s.outliers = map.Integer("outliers", -1);
  if (s.observations < 0 || s.outliers < 0) {
    throw Error("observations and outliers must be given as counts", map.Where(), "write both as whole numbers >= 0");
  }
  s.mean_px = map.Number("mean_px");
  s.max_px = map.Number("max_px");
  s.rms_px = map.Number("rms_px");
  s.mean_mm = map.Number("mean_mm");
  s.max_mm = map.Number("max_mm");
  s.rms_mm = map.Number("rms_mm");
  map.RejectUnknown();
  return s;
}

}  // namespace

double Registration::rotation_sigma_deg() const {
  return std::sqrt(covariance.diagonal().head<3>().maxCoeff()) * 180.0 / M_PI;
}
double Registration::translation_sigma_mm() const {
  return 1e3 * std::sqrt(covariance.diagonal().segment<3>(3).maxCoeff());
}
double Registration::phase_shift_sigma_ms() const { return 1e3 * std::sqrt(covariance(6, 6)); }

void WriteRegistrationYaml(const std::string& path, const Registration& registration) {
  std::ostringstream out;
  out << "# A dynaguide spatiotemporal registration of the 4D scan to the video (dynaguide register).\n"
         "# Metres and seconds; video time t is scan phase frac((t + phase_shift_s) / period_s).\n";
  out << "T_C_S:  # scan frame S to the left camera frame C, row-major\n" << MatrixRows(registration.T_C_S);
  char line[160];
  std::snprintf(line, sizeof line, "phase_shift_s: %.17g\nperiod_s: %.17g\ncycles: %.17g\n", registration.phase_shift_s,
                registration.period_s, registration.cycles);
  out << line << "residuals:  # reprojection, over the observations the robust fit kept\n";
  for (const auto& [name, stats] : {std::pair{"left", &registration.left}, std::pair{"right", &registration.right}}) {
    out << "  " << name << ": {";
    const std::array<double, 8> values = StatsValues(*stats);
    for (size_t k = 0; k < values.size(); ++k) {
      std::snprintf(line, sizeof line, "%s%s: %.10g", k ? ", " : "", kStatsKeys[k], values[k]);
      out << line;
    }
    out << "}\n";
  }
  out << "covariance:  # of (rotation vector rad, translation m, phase shift s)\n" << MatrixRows(registration.covariance);
  std::ofstream file(path);
  if (!(file << out.str())) {
    throw Error("cannot write the registration", path, "check that the directory exists and is writable");
  }
}

Registration ReadRegistrationYaml(const std::string& path) {
  const std::string text = ReadTextFile(path, "registration file", "give the file dynaguide register --out wrote");
  const YamlMap map(ParseYaml(text, path), path, "");
  Registration r;
  r.T_C_S = ReadMatrix(map, "T_C_S", 4, 4);
  const Eigen::Matrix3d R = r.T_C_S.topLeftCorner<3, 3>();
  if (!((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-6 && R.determinant() > 0 &&
        r.T_C_S.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1)))) {
    throw Error("T_C_S is not a rigid transform (rotation and translation, last row 0 0 0 1)", map.Where("T_C_S"),
                "write the matrix dynaguide register gave, with all its digits");
  }
  r.phase_shift_s = map.Number("phase_shift_s");
  r.period_s = map.Number("period_s");
  r.cycles = map.Number("cycles");
  if (!(r.period_s > 0)) throw Error("period_s must be positive", map.Where("period_s"), "give the scan's period");
  const YamlMap residuals = map.Map("residuals");
  r.left = ReadStats(residuals.Map("left"));
  r.right = ReadStats(residuals.Map("right"));
  residuals.RejectUnknown();
  r.covariance = ReadMatrix(map, "covariance", 7, 7);
  map.RejectUnknown();
  return r;
}

void WriteRegistrationH5(io::H5Writer* file, const std::string& group, const Registration& registration) {
  file->CreateGroup(group);
  file->WriteMatrix(group + "/T_C_S", registration.T_C_S);
  file->WriteScalar(group + "/phase_shift_s", registration.phase_shift_s);
  file->WriteScalar(group + "/period_s", registration.period_s);
  file->WriteScalar(group + "/cycles", registration.cycles);
  file->WriteMatrix(group + "/covariance", registration.covariance);
  for (const auto& [name, stats] : {std::pair{"/left", &registration.left}, std::pair{"/right", &registration.right}}) {
    const std::array<double, 8> values = StatsValues(*stats);
    for (size_t k = 0; k < values.size(); ++k) file->WriteScalar(group + name + "/" + kStatsKeys[k], values[k]);
  }
}

std::vector<Eigen::Vector2d> ReadFiducialPixels(const std::string& path) {
  std::istringstream file(ReadTextFile(path, "fiducial pixel file", "give a text file of u,v lines"));
  std::vector<Eigen::Vector2d> uv;
  std::string line;
  for (int number = 1; std::getline(file, line); ++number) {
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[line.find_first_not_of(" \t")] == '#') continue;
    for (char& c : line) c = c == ',' ? ' ' : c;
    std::istringstream fields(line);
    double u, v;
    std::string rest;
    if (!(fields >> u >> v) || (fields >> rest) || !std::isfinite(u) || !std::isfinite(v)) {
      throw Error("expected two numbers u,v", path + ":" + std::to_string(number),
                  "write one fiducial per line: its pixel in the first left frame");
    }
    uv.emplace_back(u, v);
  }
  if (uv.empty()) throw Error("no fiducial pixels", path, "write one u,v line per fiducial, in the scan's order");
  return uv;
}

}  // namespace dg::io
