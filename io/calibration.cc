#include "io/calibration.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <tuple>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

#include "io/calibration_formats.h"
#include "io/calibration_keys.h"
#include "io/units.h"
#include "sim/error.h"
#include "sim/log.h"

namespace dg::io {
namespace {

Eigen::Matrix3d CrossMatrix(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(),  //
      v.z(), 0, -v.x(),   //
      -v.y(), v.x(), 0;
  return m;
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

// A stereo endoscope's baseline is 3 to 10 mm and a bench rig's a few
// centimetres. OpenCV gives T in the unit of the calibration target's square
// size, which no file records: a target measured in millimetres gives a
// baseline of "5 metres", one measured in squares (the stereo_calib sample's
// default) a few units, and every depth in the run would follow.
constexpr double kSmallestBaseline_m = 0.5e-3, kLargestBaseline_m = 0.25;

const std::string kStateUnit =
    "state T's unit: calibration_units: mm in the scene (dynaguide track: --calib-units mm), or the square's side "
    "in metres for T in chessboard squares (calibration_units: 0.0025 for squares of 2.5 mm)";

void CheckBaseline(const CalibrationKeys& file, const std::string& key, const Eigen::Vector3d& T_m,
                   double metres_per_unit) {
  const double baseline_m = T_m.norm();
  if (!(baseline_m > 0) || !std::isfinite(baseline_m)) {
    file.Fail(key, "is zero or not finite: the two cameras would be at one place",
              "give the right camera's translation from the stereo calibration (cv::stereoCalibrate's T)");
  }
  char units[64];
  std::snprintf(units, sizeof units, "%g m per unit", metres_per_unit);
  const bool in_metres = metres_per_unit == 1.0;
  char what[320];
  if (baseline_m > kLargestBaseline_m) {
    std::snprintf(what, sizeof what, "gives a baseline of %.4g m, not a stereo endoscope's (3-10 mm): T is probably in %s",
                  baseline_m,
                  in_metres ? "millimetres (or in chessboard squares, as OpenCV's stereo_calib sample gives it)"
                            : "a smaller unit than calibration_units says");
    file.Fail(key, what,
              in_metres ? "give T in metres (divide it by 1000), or " + kStateUnit
                        : "check calibration_units (" + std::string(units) +
                              ") against the unit of the square size the calibration was given");
  }
  if (baseline_m < kSmallestBaseline_m) {
    std::snprintf(what, sizeof what,
                  "gives a baseline of %.3g mm, less than any stereo endoscope's (3-10 mm): T is probably in %s",
                  baseline_m * 1e3,
                  in_metres ? "a larger unit than metres" : "metres, while calibration_units scales it");
    file.Fail(key, what,
              in_metres ? "check T against the square size the calibration was given"
                        : "check calibration_units (" + std::string(units) + "); leave it out for T in metres");
  }
}

// A stereo endoscope's cameras sit side by side, a few millimetres apart,
// looking the same way; a calibration that says otherwise is most often one
// with left and right swapped, T's sign flipped, or poorly conditioned views,
// and every depth would follow. Warned of, not refused: a bench rig or a
// vertical pair may be meant.
constexpr double kTypicalBaselineMin_m = 2e-3, kTypicalBaselineMax_m = 20e-3;
constexpr double kLargestDepthShare = 0.25;  // of the baseline, along the optical axis

void WarnOfUnlikelyPlacement(const CalibrationKeys& file, const std::string& key, const StereoCalibration& pair) {
  const Eigen::Vector3d right_centre_m = -pair.R.transpose() * pair.T_m;  // in the left camera's frame
  const double baseline_m = right_centre_m.norm();
  const std::string where = file.path() + " (" + key + ")";
  spdlog::logger& log = Logger("io");
  if (baseline_m < kTypicalBaselineMin_m || baseline_m > kTypicalBaselineMax_m) {
    log.warn("{}: a baseline of {:.2f} mm, outside a stereo endoscope's {:.0f}-{:.0f} mm; check T's unit and the "
             "board's square size",
             where, baseline_m * 1e3, kTypicalBaselineMin_m * 1e3, kTypicalBaselineMax_m * 1e3);
  }
  const bool horizontal = std::abs(right_centre_m.x()) >= std::abs(right_centre_m.y());
  if (horizontal && right_centre_m.x() < 0) {
    log.warn("{}: the right camera sits {:.2f} mm to the LEFT of the left one (T = [{:.4g} {:.4g} {:.4g}] mm): "
             "left and right are probably swapped, in the calibration or in the video",
             where, -right_centre_m.x() * 1e3, pair.T_m.x() * 1e3, pair.T_m.y() * 1e3, pair.T_m.z() * 1e3);
  }
  if (std::abs(right_centre_m.z()) > kLargestDepthShare * baseline_m) {
    log.warn("{}: the right camera sits {:.2f} mm ahead of or behind the left one, {:.0f}% of the baseline "
             "(a side-by-side pair: under {:.0f}%); the calibration's views may not have constrained it",
             where, right_centre_m.z() * 1e3, 100 * std::abs(right_centre_m.z()) / baseline_m,
             100 * kLargestDepthShare);
  }
}

// T, and the translations in the rectification (the last columns of P1 and
// P2, and Q's last row, which divides by the baseline), into metres.
void ScaleTranslations(double metres_per_unit, StereoCalibration* calibration) {
  calibration->T_m *= metres_per_unit;
  if (auto& rectification = calibration->rectification) {
    rectification->P1.col(3) *= metres_per_unit;
    rectification->P2.col(3) *= metres_per_unit;
    rectification->Q.row(3) /= metres_per_unit;
  }
}

std::string Recognised(const std::vector<CalibrationKeys>& files, const std::vector<CalibrationLayout>& layouts) {
  std::string text;
  for (size_t i = 0; i < files.size(); ++i) {
    text += (i ? ", " : "") + files[i].path() + " as " + LayoutName(layouts[i]);
  }
  return text;
}

}  // namespace

std::string CalibrationSource::Describe() const {
  std::string text;
  for (const std::string& file : files) text += (text.empty() ? "" : " + ") + file;
  return text.empty() ? "no calibration file" : text;
}

double CalibrationMetresPerUnit(const std::string& text, const std::string& where) {
  const std::string fix =
      "use m, cm, mm or um, or metres per unit as a number (0.025 for T in chessboard squares of 25 mm)";
  char* end = nullptr;
  const double number = std::strtod(text.c_str(), &end);
  if (!text.empty() && end == text.c_str() + text.size()) {
    if (!(number > 0) || !std::isfinite(number)) {
      throw Error("the calibration's unit must be positive (got " + text + ")", where, fix);
    }
    return number;
  }
  try {
    return MetresPerUnit(text, where);
  } catch (const Error&) {
    throw Error("unknown unit '" + text + "' for the calibration's T", where, fix);
  }
}

StereoCalibration ReadStereoCalibration(const CalibrationSource& source, const std::optional<ImageSize>& video_size) {
  if (source.files.empty() || source.files.size() > 3) {
    throw Error(std::to_string(source.files.size()) + " calibration files given", source.Describe(),
                kAcceptedCalibrations);
  }
  std::vector<CalibrationKeys> files;
  std::vector<CalibrationLayout> layouts;
  for (const std::string& path : source.files) {
    files.emplace_back(path);
    layouts.push_back(RecogniseLayout(files.back()));
  }
  using Layout = CalibrationLayout;
  const auto find = [&](Layout layout) {
    return std::find(layouts.begin(), layouts.end(), layout) - layouts.begin();
  };
  StereoCalibration calibration;
  const CalibrationKeys* T_file = nullptr;  // the file and key T is read from, for the baseline's message
  std::string T_key = "T";
  std::optional<std::pair<int, int>> size;
  if (files.size() == 1 && layouts[0] == Layout::kDynaguide) {
    const CalibrationKeys& file = files[0];
    if (file.Has("image_size")) size = file.ImageSize("image_size");
    calibration.left = ReadCamera(file, "K1", "D1");
    calibration.right = ReadCamera(file, "K2", "D2");
    ReadExtrinsics(file, &calibration);
    T_file = &file;
  } else if (files.size() == 2 && find(Layout::kStereoCalibIntrinsics) < 2 && find(Layout::kExtrinsics) < 2) {
    const CalibrationKeys& intrinsics = files[find(Layout::kStereoCalibIntrinsics)];
    T_file = &files[find(Layout::kExtrinsics)];
    calibration.left = ReadCamera(intrinsics, "M1", "D1");
    calibration.right = ReadCamera(intrinsics, "M2", "D2");
    ReadExtrinsics(*T_file, &calibration);
  } else if (files.size() >= 2 && layouts[0] == Layout::kCameraInfo && layouts[1] == Layout::kCameraInfo &&
             (files.size() == 2 || layouts[2] == Layout::kExtrinsics)) {
    const CameraInfo left = ReadCameraInfo(files[0]), right = ReadCameraInfo(files[1]);
    calibration.left = left.camera;
    calibration.right = right.camera;
    if (left.camera.width != right.camera.width || left.camera.height != right.camera.height) {
      throw Error("the two cameras' image sizes differ (image_width, image_height)", source.Describe(),
                  "give the camera_info of the two cameras that recorded the stereo video");
    }
    size = std::make_pair(left.camera.width, left.camera.height);
    std::string why_not;
    const bool from_pair = ExtrinsicsFromCameraInfos(left, right, files[0], &calibration, &why_not);
    if (files.size() == 2) {
      if (!from_pair) {
        throw Error("the two camera_info files give no stereo extrinsics (R, T): " + why_not, source.Describe(),
                    "add the stereo extrinsics as a third file, as OpenCV's stereo_calib writes extrinsics.yml "
                    "(R T): calibration: [left.yaml, right.yaml, extrinsics.yml]");
      }
      T_file = &files[1];
      T_key = "projection_matrix";
    } else {
      if (from_pair) {
        throw Error("both the camera_info pair (the right camera's projection_matrix) and " + files[2].path() +
                        " give the stereo extrinsics",
                    source.Describe(), "give the two camera_info files alone, or drop the extrinsics file");
      }
      T_file = &files[2];
      ReadExtrinsics(*T_file, &calibration);
    }
  } else {
    throw Error("these files do not make one stereo calibration (read " + Recognised(files, layouts) + ")",
                source.Describe(), kAcceptedCalibrations);
  }
  ScaleTranslations(source.metres_per_unit, &calibration);
  CheckBaseline(*T_file, T_key, calibration.T_m, source.metres_per_unit);
  WarnOfUnlikelyPlacement(*T_file, T_key, calibration);

  if (!size && video_size) size = std::make_pair(video_size->width, video_size->height);
  if (!size) {
    throw Error("the calibration gives no image size and there is no video to take it from", source.Describe(),
                "add image_size: [width, height] to the calibration, or read it with the video it calibrates "
                "(a scene's video:, or dynaguide track with its input)");
  }
  for (CameraCalibration* camera : {&calibration.left, &calibration.right}) {
    std::tie(camera->width, camera->height) = *size;
  }
  return calibration;
}

}  // namespace dg::io
