#include "io/calibration.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <tuple>

#include <Eigen/Core>
#include <Eigen/LU>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

#include "io/input_file.h"
#include "sim/error.h"

namespace dg::io {
namespace {

const std::string kRecalibrate =
    "correct the key, or write the file again with dynaguide calibrate or OpenCV's stereoCalibrate";

bool IsSupportedDistortionCount(int count) { return count == 4 || count == 5 || count == 8; }

Eigen::Matrix3d CrossMatrix(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(),  //
      v.z(), 0, -v.x(),   //
      -v.y(), v.x(), 0;
  return m;
}

// The keys of one calibration file, each read with a check of its shape so
// that an error names the key.
class CalibrationFile {
 public:
  explicit CalibrationFile(const std::string& path) : path_(path) {
    // Checked first: OpenCV would also log its own error for a missing file.
    RequireRegularFile(path, "calibration file", "check the path");
    try {
      storage_.open(path, cv::FileStorage::READ);
    } catch (const cv::Exception& error) {
      throw Error("cannot parse calibration file: " + error.err, path,
                  "check that it is OpenCV FileStorage YAML or XML");
    }
    if (!storage_.isOpened()) {
      throw Error("cannot open calibration file", path, "check that it is readable");
    }
  }

  bool Has(const std::string& key) const { return !storage_[key].empty(); }

  // A rows x cols matrix (a vector in either orientation when rows or cols is 1).
  Eigen::MatrixXd Matrix(const std::string& key, int rows, int cols) const {
    const cv::Mat mat = Mat(key);
    const bool vector_ok = (rows == 1 || cols == 1) &&
                           mat.total() == static_cast<size_t>(rows * cols) &&
                           (mat.rows == 1 || mat.cols == 1);
    if (!vector_ok && (mat.rows != rows || mat.cols != cols)) {
      Fail(key, "expected a " + std::to_string(rows) + "x" + std::to_string(cols) +
                    " matrix, found " + std::to_string(mat.rows) + "x" + std::to_string(mat.cols));
    }
    Eigen::MatrixXd matrix;
    cv::cv2eigen(mat.reshape(1, rows), matrix);
    return matrix;
  }

  // Distortion coefficients as a row or column of 4, 5 or 8.
  void Distortion(const std::string& key, CameraCalibration* camera) const {
    const cv::Mat mat = Mat(key);
    const int count = static_cast<int>(mat.total());
    if ((mat.rows != 1 && mat.cols != 1) || !IsSupportedDistortionCount(count)) {
      Fail(key,
           "expected 4, 5 or 8 distortion coefficients in a row, found a " +
               std::to_string(mat.rows) + "x" + std::to_string(mat.cols) + " matrix",
           "calibrate without the thin-prism and tilt terms (no CALIB_THIN_PRISM_MODEL or "
           "CALIB_TILTED_MODEL)");
    }
    camera->num_distortion = count;
    camera->distortion.fill(0.0);
    for (int i = 0; i < count; ++i) camera->distortion[i] = mat.at<double>(i);
  }

  // image_size as [w, h], as cv::FileStorage writes a cv::Size.
  std::pair<int, int> ImageSize(const std::string& key) const {
    const cv::FileNode node = Node(key);
    if (!node.isSeq() || node.size() != 2 || !node[0].isInt() || !node[1].isInt() ||
        static_cast<int>(node[0]) <= 0 || static_cast<int>(node[1]) <= 0) {
      Fail(key, "expected [width, height] in pixels", kRecalibrate);
    }
    return {static_cast<int>(node[0]), static_cast<int>(node[1])};
  }

  [[noreturn]] void Fail(const std::string& key, const std::string& problem,
                         const std::string& fix = kRecalibrate) const {
    throw Error(key + ": " + problem, path_ + ": key " + key, fix);
  }

 private:
  cv::FileNode Node(const std::string& key) const {
    const cv::FileNode node = storage_[key];
    if (node.empty()) Fail(key, "missing", "add " + key + ", or " + kRecalibrate);
    return node;
  }

  cv::Mat Mat(const std::string& key) const {
    cv::Mat mat;
    try {
      Node(key) >> mat;
    } catch (const cv::Exception& error) {
      Fail(key, "not a matrix: " + error.err);
    }
    if (mat.empty() || mat.channels() != 1) Fail(key, "expected an opencv-matrix");
    mat.convertTo(mat, CV_64F);
    return mat;
  }

  std::string path_;
  cv::FileStorage storage_;
};

CameraCalibration ReadCamera(const CalibrationFile& file, const std::string& index,
                             std::pair<int, int> image_size) {
  CameraCalibration camera;
  camera.K = file.Matrix("K" + index, 3, 3);
  file.Distortion("D" + index, &camera);
  std::tie(camera.width, camera.height) = image_size;
  return camera;
}

void CheckRotation(const CalibrationFile& file, const Eigen::Matrix3d& R) {
  const double orthogonality = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  if (orthogonality > 1e-6 || R.determinant() < 0) {
    file.Fail("R", "not a rotation (|R^T R - I| = " + std::to_string(orthogonality) +
                       ", det = " + std::to_string(R.determinant()) + ")");
  }
}

void WriteMatrix(cv::FileStorage& storage, const std::string& key, const Eigen::MatrixXd& matrix) {
  cv::Mat mat;
  cv::eigen2cv(matrix, mat);
  storage << key << mat;
}

void WriteCamera(cv::FileStorage& storage, const std::string& index,
                 const CameraCalibration& camera) {
  DG_CHECK(IsSupportedDistortionCount(camera.num_distortion));
  WriteMatrix(storage, "K" + index, camera.K);
  WriteMatrix(
      storage, "D" + index,
      Eigen::Map<const Eigen::RowVectorXd>(camera.distortion.data(), camera.num_distortion));
}

}  // namespace

Eigen::Matrix3d StereoCalibration::Essential() const { return CrossMatrix(T_m) * R; }

Eigen::Matrix3d StereoCalibration::Fundamental() const {
  return right.K.inverse().transpose() * Essential() * left.K.inverse();
}

void WriteStereoCalibration(const std::string& path, const StereoCalibration& calibration) {
  const CameraCalibration &left = calibration.left, &right = calibration.right;
  if (left.width != right.width || left.height != right.height) {
    throw Error("the two cameras' image sizes differ (" + std::to_string(left.width) + "x" +
                    std::to_string(left.height) + " and " + std::to_string(right.width) + "x" +
                    std::to_string(right.height) + "); the file holds one image_size",
                path, "give both cameras the size of the stereo images");
  }
  cv::FileStorage storage;
  try {
    storage.open(path, cv::FileStorage::WRITE);
  } catch (const cv::Exception& error) {
    throw Error("cannot write calibration file: " + error.err, path,
                "check that the directory exists and is writable");
  }
  if (!storage.isOpened()) {
    throw Error("cannot write calibration file", path,
                "check that the directory exists and is writable");
  }
  WriteCamera(storage, "1", left);
  WriteCamera(storage, "2", right);
  WriteMatrix(storage, "R", calibration.R);
  WriteMatrix(storage, "T", calibration.T_m);
  WriteMatrix(storage, "E", calibration.Essential());
  WriteMatrix(storage, "F", calibration.Fundamental());
  storage << "image_size" << cv::Size(left.width, left.height);
  if (const auto& rectification = calibration.rectification) {
    WriteMatrix(storage, "R1", rectification->R1);
    WriteMatrix(storage, "R2", rectification->R2);
    WriteMatrix(storage, "P1", rectification->P1);
    WriteMatrix(storage, "P2", rectification->P2);
    WriteMatrix(storage, "Q", rectification->Q);
  }
  storage.release();
}

namespace {

// The stereo baseline |T| in metres. A stereo endoscope's is 3 to 10 mm and
// a bench rig's a few centimetres; OpenCV gives T in the unit of the
// calibration target's square size, so a target measured in millimetres
// gives a baseline of "5 metres", which every depth in the run would follow.
void CheckBaseline(const CalibrationFile& file, const Eigen::MatrixXd& T) {
  constexpr double kLargestBaseline_m = 0.25;
  const double baseline = T.norm();
  if (!(baseline > 0) || !std::isfinite(baseline)) {
    file.Fail("T", "is zero or not finite: the two cameras would be at one place",
              "give the right camera's translation from the stereo calibration (cv::stereoCalibrate's T)");
  }
  if (baseline > kLargestBaseline_m) {
    char what[160];
    std::snprintf(what, sizeof what,
                  "gives a baseline of %.4g m, not a stereo endoscope's (3-10 mm): T is probably in millimetres",
                  baseline);
    file.Fail("T", what,
              "give T in metres (divide it by 1000), or calibrate again with the target's square size in metres");
  }
}

}  // namespace

StereoCalibration ReadStereoCalibration(const std::string& path) {
  const CalibrationFile file(path);
  StereoCalibration calibration;
  const std::pair<int, int> image_size = file.ImageSize("image_size");
  calibration.left = ReadCamera(file, "1", image_size);
  calibration.right = ReadCamera(file, "2", image_size);
  calibration.R = file.Matrix("R", 3, 3);
  CheckRotation(file, calibration.R);
  calibration.T_m = file.Matrix("T", 3, 1);
  CheckBaseline(file, calibration.T_m);
  // E and F follow from the rest and are recomputed, not read.
  const std::array<const char*, 5> rectification_keys = {"R1", "R2", "P1", "P2", "Q"};
  const bool any = std::any_of(rectification_keys.begin(), rectification_keys.end(),
                               [&](const char* key) { return file.Has(key); });
  if (any) {
    for (const char* key : rectification_keys) {
      if (!file.Has(key)) {
        file.Fail(key, "missing while other rectification keys are given",
                  "give all of R1 R2 P1 P2 Q (as stereoRectify returns them), or none");
      }
    }
    calibration.rectification = StereoCalibration::Rectification{
        file.Matrix("R1", 3, 3), file.Matrix("R2", 3, 3), file.Matrix("P1", 3, 4),
        file.Matrix("P2", 3, 4), file.Matrix("Q", 4, 4)};
  }
  return calibration;
}

}  // namespace dg::io
