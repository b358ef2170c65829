#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace dg::io {

// The top-level keys of one calibration file, whichever of the two syntaxes
// calibration tools write: OpenCV FileStorage (YAML with its %YAML:1.0 header,
// XML or JSON; matrices as opencv-matrix) or plain YAML as ROS writes a
// camera_info (matrices as {rows, cols, data}), which FileStorage refuses for
// its missing header. Each value is read with a check of its shape, so that
// an error names the file and the key.
class CalibrationKeys {
 public:
  // @throws dg::Error for a missing, unreadable or unparsable file.
  explicit CalibrationKeys(const std::string& path);

  const std::string& path() const { return path_; }
  bool Has(const std::string& key) const { return entries_.count(key) > 0; }
  std::string KeyList() const;  // the file's keys, for the message of an unrecognised file

  // A rows x cols matrix (a vector in either orientation when rows or cols is 1).
  Eigen::MatrixXd Matrix(const std::string& key, int rows, int cols) const;
  // A row or column of any length, as a column.
  Eigen::VectorXd Vector(const std::string& key) const;
  int PositiveInteger(const std::string& key) const;
  // [w, h], as cv::FileStorage writes a cv::Size.
  std::pair<int, int> ImageSize(const std::string& key) const;
  std::string Text(const std::string& key) const;

  [[noreturn]] void Fail(const std::string& key, const std::string& problem, const std::string& fix) const;
  [[noreturn]] void Fail(const std::string& key, const std::string& problem) const;

  // One value, whichever syntax gave it.
  struct Entry {
    enum class Kind { kMatrix, kNumbers, kText, kOther };
    Kind kind = Kind::kOther;
    int rows = 0, cols = 0;       // kMatrix
    std::vector<double> numbers;  // kMatrix (row-major) and kNumbers (a scalar or a list)
    bool integers = false;        // kNumbers: every number written as an integer
    std::string text;             // kText; for kOther, why it is not a matrix
  };

 private:
  const Entry& Get(const std::string& key) const;

  std::string path_;
  std::vector<std::string> keys_;  // in file order
  std::map<std::string, Entry> entries_;
};

// The fix for a bad key that names the tools that write a calibration.
extern const char* const kRecalibrate;

}  // namespace dg::io
