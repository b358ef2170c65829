#include "tools/preop/fiducial_file.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "sim/error.h"

namespace dg::tools::preop {
namespace {

using Json = nlohmann::json;

// RAS to LPS: x and y change sign.
Eigen::Vector3d FromFrame(const Eigen::Vector3d& p_mm, const std::string& frame, const std::string& where) {
  if (frame == "LPS") return 1e-3 * p_mm;
  if (frame == "RAS") return 1e-3 * Eigen::Vector3d(-p_mm.x(), -p_mm.y(), p_mm.z());
  throw Error("coordinate system '" + frame + "' is neither LPS nor RAS", where,
              "save the markups from 3D Slicer, which writes LPS or RAS");
}

Eigen::Matrix3Xd ToMatrix(const std::vector<Eigen::Vector3d>& points, const std::string& path) {
  if (points.empty()) throw Error("no fiducial in the file", path, "mark the fiducials' centres at the CT's first phase");
  Eigen::Matrix3Xd matrix(3, points.size());
  for (size_t i = 0; i < points.size(); ++i) matrix.col(i) = points[i];
  return matrix;
}

Eigen::Matrix3Xd ReadMarkupsJson(const std::string& path) {
  std::ifstream file(path);
  Json json;
  try {
    json = Json::parse(file);
  } catch (const Json::exception& e) {
    throw Error(std::string("not a markups file: ") + e.what(), path, "save it from 3D Slicer's Markups module");
  }
  if (!json.contains("markups") || !json["markups"].is_array() || json["markups"].empty()) {
    throw Error("no \"markups\" array", path, "save it from 3D Slicer's Markups module (.mrk.json)");
  }
  const Json& markup = json["markups"][0];
  const std::string frame = markup.value("coordinateSystem", "LPS");  // Slicer's default since 4.11
  const std::string units = markup.value("coordinateUnits", "mm");
  if (units != "mm") throw Error("coordinateUnits '" + units + "'", path, "save the markups in mm");
  std::vector<Eigen::Vector3d> points;
  for (const Json& point : markup.value("controlPoints", Json::array())) {
    const Json& p = point.contains("position") ? point["position"] : Json();
    if (!p.is_array() || p.size() != 3 || !p[0].is_number() || !p[1].is_number() || !p[2].is_number()) {
      throw Error(fmt::format("control point {} has no position [x, y, z]", points.size()), path,
                  "save the markups from 3D Slicer");
    }
    points.push_back(FromFrame({p[0].get<double>(), p[1].get<double>(), p[2].get<double>()}, frame, path));
  }
  return ToMatrix(points, path);
}

std::vector<std::string> Fields(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream stream(line);
  for (std::string field; std::getline(stream, field, ',');) fields.push_back(field);
  return fields;
}

bool ParseXyz(const std::vector<std::string>& fields, size_t first, Eigen::Vector3d* p) {
  if (fields.size() < first + 3) return false;
  for (int c = 0; c < 3; ++c) {
    std::size_t used = 0;
    try {
      (*p)[c] = std::stod(fields[first + c], &used);
    } catch (const std::exception&) {
      return false;
    }
    if (used == 0) return false;
  }
  return true;
}

// .fcsv and .csv: points from column `first` on, the frame from an .fcsv header.
Eigen::Matrix3Xd ReadTable(const std::string& path, bool fcsv) {
  std::ifstream file(path);
  std::string frame = fcsv ? "RAS" : "LPS";
  std::vector<Eigen::Vector3d> points;
  int number = 0;
  for (std::string line; std::getline(file, line);) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    const std::string where = fmt::format("{}, line {}", path, number);
    if (line[0] == '#') {
      const std::string key = "CoordinateSystem =";
      if (const size_t at = line.find(key); fcsv && at != std::string::npos) {
        std::string value = line.substr(at + key.size());
        value.erase(0, value.find_first_not_of(' '));
        frame = value == "0" ? "RAS" : value == "1" ? "LPS" : value;
      }
      continue;
    }
    Eigen::Vector3d p_mm;
    if (!ParseXyz(Fields(line), fcsv ? 1 : 0, &p_mm)) {
      if (!fcsv && points.empty() && number == 1) continue;  // a CSV header line
      throw Error("not a point: '" + line + "'", where,
                  fcsv ? "save the list from 3D Slicer (columns id,x,y,z,...)" : "write x,y,z in mm, one point a line");
    }
    points.push_back(FromFrame(p_mm, frame, where));
  }
  return ToMatrix(points, path);
}

bool EndsWith(const std::string& text, const std::string& end) {
  return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}

}  // namespace

Eigen::Matrix3Xd ReadFiducialFile(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) {
    throw Error("no such file", path, "give the fiducials' file (.mrk.json, .fcsv or .csv)");
  }
  if (EndsWith(path, ".json")) return ReadMarkupsJson(path);
  if (EndsWith(path, ".fcsv")) return ReadTable(path, true);
  if (EndsWith(path, ".csv")) return ReadTable(path, false);
  throw Error("unknown fiducial file type", path,
              "give a 3D Slicer markups file (.mrk.json), a fiducial list (.fcsv) or x,y,z in mm (.csv)");
}

}  // namespace dg::tools::preop
