// The calibration files users bring: OpenCV's stereo_calib pair (opencv-doc's
// real intrinsics.yml), OpenCV's per-camera calibration output (opencv-doc's
// real left_intrinsics.yml), ROS camera_info files, dynaguide's own layout
// without an image size, and the scene's calibration keys.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

#include <spdlog/sinks/ringbuffer_sink.h>

#include "io/calibration.h"
#include "io/scene.h"
#include "sim/error.h"
#include "sim/log.h"
#include "tests/support/real_data.h"

namespace dg::io {
namespace {

namespace fs = std::filesystem;
using Catch::Contains;

const std::string kOpencvData = "/usr/share/doc/opencv-doc/examples/data/";
const ImageSize kVideo{640, 480};  // the size of opencv-doc's left*.jpg / right*.jpg

std::string OutputPath(const std::string& name) {
  const fs::path dir = fs::path(DG_BINARY_DIR) / "calibration_formats_test";
  fs::create_directories(dir);
  return (dir / name).string();
}

Eigen::MatrixXd ToEigen(const cv::Mat& mat) {
  Eigen::MatrixXd matrix;
  cv::cv2eigen(mat, matrix);
  return matrix;
}

cv::Mat Stored(const std::string& path, const std::string& key) {
  cv::FileStorage storage(path, cv::FileStorage::READ);
  REQUIRE(storage.isOpened());
  cv::Mat mat;
  storage[key] >> mat;
  REQUIRE(!mat.empty());
  return mat;
}

void RequireDistortion(const CameraCalibration& camera, const cv::Mat& written) {
  REQUIRE(camera.num_distortion == static_cast<int>(written.total()));
  for (int i = 0; i < camera.num_distortion; ++i) REQUIRE(camera.distortion[i] == written.at<double>(i));
}

// The stereo pair the tests' extrinsics describe: 4.2 mm baseline, toed in.
struct Extrinsics {
  cv::Mat R, T;  // T in the unit the file is written in
};
Extrinsics Pair(double units_per_metre) {
  Eigen::Matrix3d R = Eigen::AngleAxisd(0.02, Eigen::Vector3d(0.2, 1, 0.1).normalized()).matrix();
  Eigen::Vector3d T = Eigen::Vector3d(-4.2e-3, 5e-5, 1e-4) * units_per_metre;
  Extrinsics e;
  cv::eigen2cv(R, e.R);
  cv::eigen2cv(T, e.T);
  return e;
}

// extrinsics.yml as OpenCV's stereo_calib sample writes it (stereo_calib.cpp:
// fs << "R" << R << "T" << T << "R1" << R1 << ...), rectified from the real intrinsics.yml.
struct Rectified {
  cv::Mat R1, R2, P1, P2, Q;
};
Rectified WriteSampleExtrinsics(const std::string& path, const std::string& intrinsics, const Extrinsics& e) {
  Rectified r;
  cv::stereoRectify(Stored(intrinsics, "M1"), Stored(intrinsics, "D1"), Stored(intrinsics, "M2"),
                    Stored(intrinsics, "D2"), cv::Size(640, 480), e.R, e.T, r.R1, r.R2, r.P1, r.P2, r.Q,
                    cv::CALIB_ZERO_DISPARITY, -1);
  cv::FileStorage fs(path, cv::FileStorage::WRITE);
  fs << "R" << e.R << "T" << e.T << "R1" << r.R1 << "R2" << r.R2 << "P1" << r.P1 << "P2" << r.P2 << "Q" << r.Q;
  return r;
}

Error ErrorOf(const CalibrationSource& source, const std::optional<ImageSize>& video = std::nullopt) {
  try {
    ReadStereoCalibration(source, video);
  } catch (const Error& error) {
    return error;
  }
  FAIL("no error reading " << source.Describe());
  throw;  // unreachable: FAIL throws
}

std::string Numbers(const cv::Mat& mat) {
  std::string text;
  for (int i = 0; i < static_cast<int>(mat.total()); ++i) {
    char number[40];
    std::snprintf(number, sizeof number, "%.17g", mat.at<double>(i));
    text += (i ? ", " : "") + std::string(number);
  }
  return text;
}

// A camera_info YAML as ROS's camera_calibration_parsers writes it
// (writeCalibrationYml: no %YAML header, matrices as rows, cols, data).
void WriteCameraInfo(const std::string& path, const std::string& name, const std::string& model, const cv::Mat& K,
                     const cv::Mat& D, const cv::Mat& R, const cv::Mat& P) {
  std::ofstream file(path);
  file << "image_width: 640\nimage_height: 480\ncamera_name: " << name << "\n"
       << "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [" << Numbers(K) << "]\n"
       << "distortion_model: " << model << "\n"
       << "distortion_coefficients:\n  rows: 1\n  cols: " << D.total() << "\n  data: [" << Numbers(D) << "]\n"
       << "rectification_matrix:\n  rows: 3\n  cols: 3\n  data: [" << Numbers(R) << "]\n"
       << "projection_matrix:\n  rows: 3\n  cols: 4\n  data: [" << Numbers(P) << "]\n";
}

}  // namespace

// opencv-doc's intrinsics.yml is a real output of the stereo_calib sample
// (M1 D1 M2 D2, no image size). With an extrinsics.yml written as the sample
// writes it, T in chessboard squares of 2 mm (the sample's default square
// size 1) and calibration units 0.002 m, K and D come back exactly, R
// exactly, T in metres, the size from the video, in either file order.
TEST_CASE("calibration formats: OpenCV stereo_calib's intrinsics.yml and extrinsics.yml", "[io][unit]") {
  const std::string intrinsics = kOpencvData + "intrinsics.yml";
  REQUIRE(fs::exists(intrinsics));
  const std::string extrinsics = OutputPath("extrinsics.yml");
  const Extrinsics pair = Pair(1 / 0.002);  // in squares
  const Rectified rectified = WriteSampleExtrinsics(extrinsics, intrinsics, pair);

  for (const std::vector<std::string>& files : {std::vector<std::string>{intrinsics, extrinsics},
                                                std::vector<std::string>{extrinsics, intrinsics}}) {
    CalibrationSource source;
    source.files = files;
    source.metres_per_unit = 0.002;
    const StereoCalibration read = ReadStereoCalibration(source, kVideo);
    REQUIRE(read.left.K == ToEigen(Stored(intrinsics, "M1")));
    REQUIRE(read.right.K == ToEigen(Stored(intrinsics, "M2")));
    RequireDistortion(read.left, Stored(intrinsics, "D1"));
    RequireDistortion(read.right, Stored(intrinsics, "D2"));
    REQUIRE(read.R == ToEigen(pair.R));
    REQUIRE(read.T_m == ToEigen(pair.T) * 0.002);
    REQUIRE(read.T_m.norm() == Approx(4.2015e-3).epsilon(1e-4));
    REQUIRE(read.left.width == 640);
    REQUIRE(read.right.height == 480);
    REQUIRE(read.rectification.has_value());
    REQUIRE(read.rectification->R1 == ToEigen(rectified.R1));
    REQUIRE(read.rectification->P1.leftCols<3>() == ToEigen(rectified.P1).leftCols<3>());
    // P2's translation column and Q's last row follow T into metres.
    REQUIRE(read.rectification->P2(0, 3) == ToEigen(rectified.P2)(0, 3) * 0.002);
    REQUIRE(read.rectification->Q(3, 2) == Approx(ToEigen(rectified.Q)(3, 2) / 0.002).epsilon(1e-15));
  }

  CalibrationSource source;
  source.files = {intrinsics, extrinsics};
  // Without the size of a video, the sample's files give none.
  source.metres_per_unit = 0.002;
  REQUIRE_THROWS_WITH(ReadStereoCalibration(source), Contains("gives no image size") && Contains("image_size"));
  // Without calibration units, T in squares is a baseline of metres: refused, naming the likely unit.
  source.metres_per_unit = 1;
  const Error unitless = ErrorOf(source, kVideo);
  REQUIRE(unitless.where() == extrinsics + ": key T");
  REQUIRE_THAT(unitless.problem(), Contains("2.101 m") && Contains("chessboard squares"));
  REQUIRE_THAT(unitless.fix(), Contains("calibration_units"));
}

// The io module's log lines while reading `source`.
std::vector<std::string> ReadLogging(const CalibrationSource& source, const std::optional<ImageSize>& video,
                                     StereoCalibration* read) {
  auto log = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(16);
  Logger("io").sinks().push_back(log);
  try {
    *read = ReadStereoCalibration(source, video);
  } catch (...) {
    Logger("io").sinks().pop_back();
    throw;
  }
  Logger("io").sinks().pop_back();
  return log->last_formatted(16);
}

// The Hamlyn heart phantom's calibration (converted from the data set's own
// text files) writes R to six digits: |R^T R - I| = 1.3e-6. It is read as
// given, R replaced by the nearest rotation with a note; a matrix off by
// 1e-3 is no rotation and is refused.
TEST_CASE("calibration formats: a rotation rounded to six digits is taken, one off by 1e-3 is refused",
          "[io][unit]") {
  const std::string hamlyn = "05_stereo_heart_phantom_hamlyn_f7_frame100/";
  CalibrationSource source;
  source.files = {testing::RealData(hamlyn + "intrinsics.yml"), testing::RealData(hamlyn + "extrinsics.yml")};
  source.metres_per_unit = 1e-3;
  StereoCalibration read;
  const std::vector<std::string> lines = ReadLogging(source, ImageSize{360, 288}, &read);
  const Eigen::MatrixXd as_written = ToEigen(Stored(source.files[1], "R"));
  CHECK((read.R.transpose() * read.R - Eigen::Matrix3d::Identity()).norm() < 1e-14);
  CHECK((read.R - as_written).norm() < 2e-6);
  CHECK(read.T_m.norm() == Approx(5.5211e-3).epsilon(1e-4));
  REQUIRE(!lines.empty());
  CHECK_THAT(lines.front(), Contains("extrinsics.yml") && Contains("R is a rotation to 1.3e-06") &&
                                Contains("nearest rotation"));

  const std::string scaled = OutputPath("extrinsics_scaled_R.yml");
  {
    cv::FileStorage fs(scaled, cv::FileStorage::WRITE);
    fs << "R" << Stored(source.files[1], "R") * 1.001 << "T" << Stored(source.files[1], "T");
  }
  source.files[1] = scaled;
  CHECK_THROWS_WITH(ReadStereoCalibration(source, ImageSize{360, 288}),
                    Contains("not a rotation") && Contains("rounding"));
}

// A calibration whose right camera sits on the left, ahead of the left
// camera by half the baseline, 30 mm from it: each is warned of, naming the
// file; a side-by-side pair 4.2 mm apart is read without a word.
TEST_CASE("calibration formats: an unlikely placement of the right camera is warned of", "[io][unit]") {
  const std::string intrinsics = kOpencvData + "intrinsics.yml";
  const auto warnings = [&](const Eigen::Vector3d& right_centre_m) {
    Extrinsics pair = Pair(1);
    Eigen::Matrix3d R;
    cv::cv2eigen(pair.R, R);
    const Eigen::Vector3d T = -R * right_centre_m;
    cv::eigen2cv(T, pair.T);
    const std::string extrinsics = OutputPath("extrinsics_placed.yml");
    WriteSampleExtrinsics(extrinsics, intrinsics, pair);
    CalibrationSource source;
    source.files = {intrinsics, extrinsics};
    StereoCalibration read;
    return ReadLogging(source, kVideo, &read);
  };
  CHECK(warnings(Eigen::Vector3d(4.2e-3, 0, 0)).empty());
  const std::vector<std::string> swapped = warnings(Eigen::Vector3d(-4.2e-3, 0, 0));
  REQUIRE(swapped.size() == 1);
  CHECK_THAT(swapped[0], Contains("extrinsics_placed.yml") && Contains("4.20 mm to the LEFT") && Contains("swapped"));
  const std::vector<std::string> ahead = warnings(Eigen::Vector3d(4.2e-3, 0, 2.1e-3));
  REQUIRE(ahead.size() == 1);
  CHECK_THAT(ahead[0], Contains("2.10 mm ahead of or behind") && Contains("45%"));
  const std::vector<std::string> wide = warnings(Eigen::Vector3d(30e-3, 0, 0));
  REQUIRE(wide.size() == 1);
  CHECK_THAT(wide[0], Contains("baseline of 30.00 mm") && Contains("2-20 mm"));
}

// The same pair written by cv::FileStorage under dynaguide's names without
// image_size: K, D, R, T exact, the size from the video.
TEST_CASE("calibration formats: dynaguide's layout without image_size takes the video's", "[io][unit]") {
  const std::string path = OutputPath("no_size.yml");
  const std::string intrinsics = kOpencvData + "intrinsics.yml";
  const Extrinsics pair = Pair(1);
  {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    fs << "K1" << Stored(intrinsics, "M1") << "D1" << Stored(intrinsics, "D1") << "K2" << Stored(intrinsics, "M2")
       << "D2" << Stored(intrinsics, "D2") << "R" << pair.R << "T" << pair.T;
  }
  const StereoCalibration read = ReadStereoCalibration(path, ImageSize{1280, 720});
  REQUIRE(read.left.K == ToEigen(Stored(intrinsics, "M1")));
  RequireDistortion(read.right, Stored(intrinsics, "D2"));
  REQUIRE(read.R == ToEigen(pair.R));
  REQUIRE(read.T_m == ToEigen(pair.T));
  REQUIRE(read.left.width == 1280);
  REQUIRE(read.left.height == 720);
  REQUIRE(!read.rectification);
  const Error error = ErrorOf(path);
  REQUIRE(error.where() == path);
  REQUIRE_THAT(error.problem(), Contains("no image size") && Contains("no video"));
}

// opencv-doc's left_intrinsics.yml is a real output of OpenCV's one-camera
// calibration sample (camera_matrix, distortion_coefficients as a column,
// image_width, image_height): a pair of such files has no baseline, so it is
// read with an extrinsics file and refused alone, saying so.
TEST_CASE("calibration formats: per-camera files need an extrinsics file", "[io][unit]") {
  const std::string camera = kOpencvData + "left_intrinsics.yml";
  REQUIRE(fs::exists(camera));
  const std::string extrinsics = OutputPath("per_camera_extrinsics.yml");
  const Extrinsics pair = Pair(1e3);  // in millimetres
  {
    cv::FileStorage fs(extrinsics, cv::FileStorage::WRITE);
    fs << "R" << pair.R << "T" << pair.T;
  }
  CalibrationSource source;
  source.files = {camera, camera, extrinsics};
  source.metres_per_unit = 1e-3;
  const StereoCalibration read = ReadStereoCalibration(source);
  REQUIRE(read.left.K == ToEigen(Stored(camera, "camera_matrix")));
  RequireDistortion(read.left, Stored(camera, "distortion_coefficients"));
  REQUIRE(read.left.width == 640);  // from the file: no video needed
  REQUIRE(read.left.height == 480);
  REQUIRE(read.R == ToEigen(pair.R));
  REQUIRE((read.T_m - ToEigen(pair.T) * 1e-3).norm() < 1e-18);  // an ulp of the millimetres' conversion (3e-19)

  source.files = {camera, camera};
  const Error alone = ErrorOf(source);
  REQUIRE_THAT(alone.problem(), Contains("give no stereo extrinsics") && Contains("rectification_matrix"));
  REQUIRE_THAT(alone.fix(), Contains("third file") && Contains("extrinsics.yml"));
}

// A stereo pair's camera_info files as ROS writes them, from OpenCV's
// stereoRectify of a known pair: R = R_right^T R_left and T = R_right^T t
// give the pair back to rounding, and the rectification is the files' own,
// with Q as stereoRectify makes it.
TEST_CASE("calibration formats: a ROS camera_info pair gives R and T", "[io][unit]") {
  const std::string intrinsics = kOpencvData + "intrinsics.yml";
  const cv::Mat K1 = Stored(intrinsics, "M1"), D1 = Stored(intrinsics, "D1");
  const cv::Mat K2 = Stored(intrinsics, "M2"), D2 = Stored(intrinsics, "D2");
  const Extrinsics pair = Pair(1);  // ROS's calibrator takes the square size in metres
  Rectified r;
  cv::stereoRectify(K1, D1, K2, D2, cv::Size(640, 480), pair.R, pair.T, r.R1, r.R2, r.P1, r.P2, r.Q,
                    cv::CALIB_ZERO_DISPARITY, 0);
  const std::string left = OutputPath("left.yaml"), right = OutputPath("right.yaml");
  WriteCameraInfo(left, "narrow_stereo/left", "plumb_bob", K1, D1, r.R1, r.P1);
  WriteCameraInfo(right, "narrow_stereo/right", "plumb_bob", K2, D2, r.R2, r.P2);

  CalibrationSource source;
  source.files = {left, right};
  const StereoCalibration read = ReadStereoCalibration(source);
  REQUIRE(read.left.K == ToEigen(K1));  // %.17g keeps every digit
  REQUIRE(read.right.K == ToEigen(K2));
  RequireDistortion(read.left, D1);
  RequireDistortion(read.right, D2);
  REQUIRE(read.left.width == 640);
  const double rotation_error = (read.R - ToEigen(pair.R)).norm();
  const double translation_error = (read.T_m - ToEigen(pair.T)).norm();
  CHECK(rotation_error < 3e-14);     // 1.4e-14: R_right^T R_left of the rectification's rotations
  CHECK(translation_error < 5e-17);  // 1.9e-17 m of a 4.2 mm baseline
  REQUIRE(read.rectification.has_value());
  REQUIRE(read.rectification->P2 == ToEigen(r.P2));
  const Eigen::MatrixXd Q = ToEigen(r.Q);
  CHECK((read.rectification->Q - Q).norm() <= 1e-15 * Q.norm());  // 0: the formula of stereoRectify

  // Swapped: the left file holds the right camera's Tx.
  source.files = {right, left};
  REQUIRE(ErrorOf(source).where() == right + ": key projection_matrix");

  // Two monocular calibrations (R = I, P = [K | 0]) give no baseline: the
  // error asks for the extrinsics, with which the three files are read.
  const cv::Mat I = cv::Mat::eye(3, 3, CV_64F);
  cv::Mat P1 = cv::Mat::zeros(3, 4, CV_64F), P2 = cv::Mat::zeros(3, 4, CV_64F);
  K1.copyTo(P1.colRange(0, 3));
  K2.copyTo(P2.colRange(0, 3));
  WriteCameraInfo(left, "left", "plumb_bob", K1, D1, I, P1);
  WriteCameraInfo(right, "right", "plumb_bob", K2, D2, I, P2);
  source.files = {left, right};
  REQUIRE_THAT(ErrorOf(source).problem(), Contains("Tx = Ty = 0"));
  const std::string extrinsics = OutputPath("ros_extrinsics.yml");
  {
    cv::FileStorage fs(extrinsics, cv::FileStorage::WRITE);
    fs << "R" << pair.R << "T" << pair.T;
  }
  source.files = {left, right, extrinsics};
  const StereoCalibration mono = ReadStereoCalibration(source);
  REQUIRE(mono.R == ToEigen(pair.R));
  REQUIRE(mono.T_m == ToEigen(pair.T));
  REQUIRE(!mono.rectification);

  // ROS's fisheye model has four coefficients that are not k1 k2 p1 p2.
  WriteCameraInfo(left, "left", "equidistant", K1, D1.colRange(0, 4), I, P1);
  REQUIRE(ErrorOf(source).where() == left + ": key distortion_model");
}

// Files of none of the accepted layouts are refused, the message naming the
// key sets accepted and no function that writes no file.
TEST_CASE("calibration formats: unrecognised files name the accepted key sets", "[io][unit]") {
  const std::string image_list = kOpencvData + "stereo_calib.xml";  // the sample's image list
  REQUIRE(fs::exists(image_list));
  const Error list = ErrorOf(image_list);
  REQUIRE(list.where() == image_list);
  REQUIRE_THAT(list.problem(), Contains("not a camera calibration") && Contains("imagelist"));
  for (const char* keys : {"K1 D1 K2 D2 R T", "M1 D1 M2 D2", "R T", "camera_matrix", "image_width"}) {
    REQUIRE_THAT(list.fix(), Contains(keys));
  }
  REQUIRE_THAT(list.fix(), !Contains("stereoRectify") && !Contains("initUndistort"));

  const std::string unknown = OutputPath("unknown_keys.yml");
  {
    cv::FileStorage fs(unknown, cv::FileStorage::WRITE);
    fs << "cameraMatrix" << cv::Mat::eye(3, 3, CV_64F) << "distCoeffs" << cv::Mat::zeros(1, 5, CV_64F);
  }
  REQUIRE_THAT(ErrorOf(unknown).problem(), Contains("cameraMatrix distCoeffs"));

  // Two halves that do not fit: intrinsics without extrinsics.
  CalibrationSource source;
  source.files = {kOpencvData + "intrinsics.yml", kOpencvData + "left_intrinsics.yml"};
  REQUIRE_THAT(ErrorOf(source, kVideo).problem(), Contains("do not make one stereo calibration"));

  // A baseline below a millimetre: T in metres read as millimetres.
  const std::string extrinsics = OutputPath("tiny_baseline.yml");
  {
    const Extrinsics pair = Pair(1);
    cv::FileStorage fs(extrinsics, cv::FileStorage::WRITE);
    fs << "R" << pair.R << "T" << pair.T;
  }
  source.files = {kOpencvData + "intrinsics.yml", extrinsics};
  source.metres_per_unit = 1e-3;
  const Error tiny = ErrorOf(source, kVideo);
  REQUIRE(tiny.where() == extrinsics + ": key T");
  REQUIRE_THAT(tiny.problem(), Contains("0.0042 mm") && Contains("probably in metres"));
}

// The scene's calibration: one path or a list, and calibration_units as a
// unit name or metres per unit.
TEST_CASE("calibration formats: the scene's calibration and calibration_units keys", "[io][unit]") {
  const fs::path dir = fs::path(OutputPath("scene"));
  fs::create_directories(dir);
  for (const char* file : {"mesh.msh", "left.avi", "right.avi", "intrinsics.yml", "extrinsics.yml"}) {
    std::ofstream(dir / file) << "";
  }
  const auto scene_with = [&](const std::string& calibration) {
    std::ofstream(dir / "scene.yaml") << "mesh: {file: mesh.msh}\n" << calibration
                                      << "video: {left: left.avi, right: right.avi, fps: 30}\n";
    return (dir / "scene.yaml").string();
  };
  Scene scene = ReadScene(scene_with("calibration: [intrinsics.yml, extrinsics.yml]\ncalibration_units: 0.025\n"));
  REQUIRE(scene.calibration.files ==
          std::vector<std::string>{(dir / "intrinsics.yml").string(), (dir / "extrinsics.yml").string()});
  REQUIRE(scene.calibration.metres_per_unit == 0.025);
  scene = ReadScene(scene_with("calibration: intrinsics.yml\ncalibration_units: mm\n"));
  REQUIRE(scene.calibration.files.size() == 1);
  REQUIRE(scene.calibration.metres_per_unit == 1e-3);
  scene = ReadScene(scene_with("calibration: intrinsics.yml\n"));
  REQUIRE(scene.calibration.metres_per_unit == 1.0);
  REQUIRE_THROWS_WITH(ReadScene(scene_with("calibration: intrinsics.yml\ncalibration_units: inches\n")),
                      Contains("unknown unit 'inches'") && Contains("calibration_units"));
  REQUIRE_THROWS_WITH(ReadScene(scene_with("calibration: [intrinsics.yml, missing.yml]\n")),
                      Contains("file not found") && Contains("missing.yml"));
  REQUIRE_THROWS_WITH(ReadScene(scene_with("calibration: []\n")), Contains("lists 0 files"));
}

}  // namespace dg::io
