#include "io/calibration_keys.h"

#include <cmath>

#include <opencv2/core.hpp>
#include <yaml-cpp/yaml.h>

#include "io/input_file.h"
#include "io/yaml_map.h"
#include "sim/error.h"

namespace dg::io {

const char* const kRecalibrate =
    "correct the key, or write the file again with dynaguide calibrate, OpenCV's stereoCalibrate or ROS's "
    "camera_calibration";

namespace {

using Entry = CalibrationKeys::Entry;

std::string Shape(int rows, int cols) { return std::to_string(rows) + "x" + std::to_string(cols); }

// OpenCV's own syntax: YAML under its "%YAML:1.0" header (which plain YAML
// readers refuse), or XML. Anything else (ROS's headerless YAML, JSON) is YAML.
bool IsFileStorageSyntax(const std::string& text) {
  const size_t start = text.find_first_not_of(" \t\r\n");
  return start != std::string::npos && (text.compare(start, 6, "%YAML:") == 0 || text[start] == '<');
}

Entry FromFileNode(const cv::FileNode& node) {
  Entry entry;
  if (node.isMap() && !node["dt"].empty()) {  // an opencv-matrix
    cv::Mat mat;
    try {
      node >> mat;
    } catch (const cv::Exception& error) {
      entry.text = "not a matrix: " + error.err;
      return entry;
    }
    if (mat.empty() || mat.channels() != 1) {
      entry.text = "expected an opencv-matrix of one channel";
      return entry;
    }
    mat.convertTo(mat, CV_64F);
    entry.kind = Entry::Kind::kMatrix;
    entry.rows = mat.rows;
    entry.cols = mat.cols;
    entry.numbers.assign(mat.begin<double>(), mat.end<double>());
  } else if (node.isMap() && node["rows"].isInt() && node["cols"].isInt() && node["data"].isSeq()) {
    entry.kind = Entry::Kind::kMatrix;
    entry.rows = static_cast<int>(node["rows"]);
    entry.cols = static_cast<int>(node["cols"]);
    for (const cv::FileNode& value : node["data"]) entry.numbers.push_back(static_cast<double>(value));
  } else if (node.isInt() || node.isReal()) {
    entry.kind = Entry::Kind::kNumbers;
    entry.integers = node.isInt();
    entry.numbers.push_back(static_cast<double>(node));
  } else if (node.isSeq()) {
    entry.kind = Entry::Kind::kNumbers;
    entry.integers = true;
    for (const cv::FileNode& value : node) {
      if (!value.isInt() && !value.isReal()) return Entry{};
      entry.integers = entry.integers && value.isInt();
      entry.numbers.push_back(static_cast<double>(value));
    }
  } else if (node.isString()) {
    entry.kind = Entry::Kind::kText;
    entry.text = static_cast<std::string>(node);
  }
  return entry;
}

// A YAML scalar as a number, and whether it is written as an integer.
bool ScalarNumber(const YAML::Node& node, double* number, bool* integer) {
  if (!node.IsScalar()) return false;
  try {
    *number = node.as<double>();
  } catch (const YAML::Exception&) {
    return false;
  }
  try {
    node.as<long long>();
    *integer = true;
  } catch (const YAML::Exception&) {
    *integer = false;
  }
  return true;
}

Entry FromYamlNode(const YAML::Node& node) {
  Entry entry;
  double number = 0;
  bool integer = false;
  if (node.IsMap() && node["rows"] && node["cols"] && node["data"] && node["data"].IsSequence()) {
    if (!ScalarNumber(node["rows"], &number, &integer) || !integer) return entry;
    entry.rows = static_cast<int>(number);
    if (!ScalarNumber(node["cols"], &number, &integer) || !integer) return entry;
    entry.cols = static_cast<int>(number);
    for (const YAML::Node& value : node["data"]) {
      if (!ScalarNumber(value, &number, &integer)) {
        entry.text = "its data holds a value that is not a number";
        return entry;
      }
      entry.numbers.push_back(number);
    }
    entry.kind = Entry::Kind::kMatrix;
  } else if (node.IsSequence()) {
    entry.integers = true;
    for (const YAML::Node& value : node) {
      if (!ScalarNumber(value, &number, &integer)) return Entry{};
      entry.integers = entry.integers && integer;
      entry.numbers.push_back(number);
    }
    entry.kind = Entry::Kind::kNumbers;
  } else if (ScalarNumber(node, &number, &integer)) {
    entry.kind = Entry::Kind::kNumbers;
    entry.integers = integer;
    entry.numbers.push_back(number);
  } else if (node.IsScalar()) {
    entry.kind = Entry::Kind::kText;
    entry.text = node.Scalar();
  }
  return entry;
}

}  // namespace

CalibrationKeys::CalibrationKeys(const std::string& path) : path_(path) {
  const std::string text = ReadTextFile(path, "calibration file", "check the path");
  if (IsFileStorageSyntax(text)) {
    cv::FileStorage storage;
    try {
      storage.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    } catch (const cv::Exception& error) {
      throw Error("cannot parse calibration file: " + error.err, path,
                  "check that it is OpenCV FileStorage YAML or XML, or a ROS camera_info YAML");
    }
    if (!storage.isOpened()) {
      throw Error("cannot parse calibration file", path,
                  "check that it is OpenCV FileStorage YAML or XML, or a ROS camera_info YAML");
    }
    for (const cv::FileNode& node : storage.root()) {
      keys_.push_back(node.name());
      entries_[node.name()] = FromFileNode(node);
    }
    return;
  }
  const YAML::Node root = ParseYaml(text, path);
  if (!root.IsMap()) {
    throw Error("expected a mapping of keys to values", path,
                "give an OpenCV FileStorage calibration or a ROS camera_info YAML");
  }
  for (const auto& item : root) {
    const std::string key = item.first.Scalar();
    keys_.push_back(key);
    entries_[key] = FromYamlNode(item.second);
  }
}

std::string CalibrationKeys::KeyList() const {
  std::string list;
  for (const std::string& key : keys_) list += (list.empty() ? "" : " ") + key;
  return list.empty() ? "none" : list;
}

const Entry& CalibrationKeys::Get(const std::string& key) const {
  const auto found = entries_.find(key);
  if (found == entries_.end()) Fail(key, "missing", "add " + key + ", or " + kRecalibrate);
  return found->second;
}

Eigen::MatrixXd CalibrationKeys::Matrix(const std::string& key, int rows, int cols) const {
  const Entry& entry = Get(key);
  if (entry.kind != Entry::Kind::kMatrix) {
    Fail(key, entry.text.empty() ? "expected an opencv-matrix (or ROS's rows, cols, data)" : entry.text);
  }
  if (static_cast<int>(entry.numbers.size()) != entry.rows * entry.cols) {
    Fail(key, "holds " + std::to_string(entry.numbers.size()) + " values for " + Shape(entry.rows, entry.cols));
  }
  const bool vector_ok = (rows == 1 || cols == 1) && entry.rows * entry.cols == rows * cols &&
                         (entry.rows == 1 || entry.cols == 1);
  if (!vector_ok && (entry.rows != rows || entry.cols != cols)) {
    Fail(key, "expected a " + Shape(rows, cols) + " matrix, found " + Shape(entry.rows, entry.cols));
  }
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      entry.numbers.data(), rows, cols);
}

Eigen::VectorXd CalibrationKeys::Vector(const std::string& key) const {
  const Entry& entry = Get(key);
  const bool matrix = entry.kind == Entry::Kind::kMatrix &&
                      static_cast<int>(entry.numbers.size()) == entry.rows * entry.cols;
  if (!matrix && entry.kind != Entry::Kind::kNumbers) Fail(key, "expected a row of numbers");
  if (matrix && entry.rows != 1 && entry.cols != 1) {
    Fail(key, "expected a row of numbers, found a " + Shape(entry.rows, entry.cols) + " matrix");
  }
  return Eigen::Map<const Eigen::VectorXd>(entry.numbers.data(), static_cast<Eigen::Index>(entry.numbers.size()));
}

int CalibrationKeys::PositiveInteger(const std::string& key) const {
  const Entry& entry = Get(key);
  if (entry.kind != Entry::Kind::kNumbers || entry.numbers.size() != 1 || !entry.integers ||
      !(entry.numbers[0] > 0)) {
    Fail(key, "expected a positive integer");
  }
  return static_cast<int>(entry.numbers[0]);
}

std::pair<int, int> CalibrationKeys::ImageSize(const std::string& key) const {
  const Entry& entry = Get(key);
  if (entry.kind != Entry::Kind::kNumbers || entry.numbers.size() != 2 || !entry.integers ||
      !(entry.numbers[0] > 0) || !(entry.numbers[1] > 0)) {
    Fail(key, "expected [width, height] in pixels");
  }
  return {static_cast<int>(entry.numbers[0]), static_cast<int>(entry.numbers[1])};
}

std::string CalibrationKeys::Text(const std::string& key) const {
  const Entry& entry = Get(key);
  if (entry.kind != Entry::Kind::kText) Fail(key, "expected a name");
  return entry.text;
}

void CalibrationKeys::Fail(const std::string& key, const std::string& problem, const std::string& fix) const {
  throw Error(key + ": " + problem, path_ + ": key " + key, fix);
}

void CalibrationKeys::Fail(const std::string& key, const std::string& problem) const {
  Fail(key, problem, kRecalibrate);
}

}  // namespace dg::io
