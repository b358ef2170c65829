#include "io/calibration.h"

#include <functional>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

#include "sim/error.h"

namespace dg::io {
namespace {

std::string OutputPath(const std::string& name) { return std::string(DG_BINARY_DIR) + "/" + name; }

// A stereo endoscope: 5 mm baseline, slightly toed-in, distinct intrinsics,
// a five-coefficient left and an eight-coefficient right distortion model.
StereoCalibration Endoscope() {
  StereoCalibration calibration;
  calibration.left.K << 800, 0, 320.5, 0, 790, 240.25, 0, 0, 1;
  calibration.left.distortion = {-0.21, 0.051, 1e-3, -5e-4, 0.012, 0, 0, 0};
  calibration.left.num_distortion = 5;
  calibration.right.K << 805, 0, 318.75, 0, 796, 238.5, 0, 0, 1;
  calibration.right.distortion = {-0.19, 0.04, -2e-4, 3e-4, 0.01, 1e-3, -2e-3, 5e-4};
  calibration.right.num_distortion = 8;
  for (CameraCalibration* camera : {&calibration.left, &calibration.right}) {
    camera->width = 640;
    camera->height = 480;
  }
  calibration.R = Eigen::AngleAxisd(0.03, Eigen::Vector3d(0.1, 1, 0.05).normalized()).matrix();
  calibration.T_m = Eigen::Vector3d(-5e-3, 1e-4, 2e-4);
  return calibration;
}

cv::Mat ToMat(const Eigen::MatrixXd& matrix) {
  cv::Mat mat;
  cv::eigen2cv(matrix, mat);
  return mat;
}

cv::Mat Distortion(const CameraCalibration& camera) {
  return cv::Mat(1, camera.num_distortion, CV_64F, const_cast<double*>(camera.distortion.data()))
      .clone();
}

// Rectification as OpenCV's stereoRectify computes it for the pair.
void AddRectification(StereoCalibration* calibration) {
  cv::Mat R1, R2, P1, P2, Q;
  cv::stereoRectify(ToMat(calibration->left.K), Distortion(calibration->left),
                    ToMat(calibration->right.K), Distortion(calibration->right), cv::Size(640, 480),
                    ToMat(calibration->R), ToMat(calibration->T_m), R1, R2, P1, P2, Q);
  StereoCalibration::Rectification rectification;
  cv::cv2eigen(R1, rectification.R1);
  cv::cv2eigen(R2, rectification.R2);
  cv::cv2eigen(P1, rectification.P1);
  cv::cv2eigen(P2, rectification.P2);
  cv::cv2eigen(Q, rectification.Q);
  calibration->rectification = rectification;
}

Eigen::MatrixXd StoredMatrix(const cv::FileStorage& storage, const std::string& key) {
  cv::Mat mat;
  storage[key] >> mat;
  REQUIRE(!mat.empty());
  Eigen::MatrixXd matrix;
  cv::cv2eigen(mat, matrix);
  return matrix;
}

Error ReadError(const std::string& path) {
  try {
    ReadStereoCalibration(path);
  } catch (const Error& error) {
    return error;
  }
  FAIL("no error reading " << path);
  throw;  // unreachable: FAIL throws
}

void RequireSameCamera(const CameraCalibration& read, const CameraCalibration& written) {
  REQUIRE(read.K == written.K);
  REQUIRE(read.distortion == written.distortion);
  REQUIRE(read.num_distortion == written.num_distortion);
  REQUIRE(read.width == written.width);
  REQUIRE(read.height == written.height);
}

// Up to scale and sign, normalised to unit Frobenius norm with a positive (2, 2).
Eigen::Matrix3d Normalised(const Eigen::Matrix3d& F) {
  return F / F.norm() * (F(2, 2) < 0 ? -1.0 : 1.0);
}

}  // namespace

// The file is what cv::FileStorage reads (D as a 1xN row, image_size as
// [w, h], E and F included), and ReadStereoCalibration gives back every digit.
TEST_CASE("calibration: write, read back through cv::FileStorage and the reader", "[io][unit]") {
  for (bool rectified : {false, true}) {
    StereoCalibration calibration = Endoscope();
    if (rectified) AddRectification(&calibration);
    const std::string path = OutputPath("calibration_round_trip.yml");
    WriteStereoCalibration(path, calibration);

    cv::FileStorage storage(path, cv::FileStorage::READ);
    REQUIRE(storage.isOpened());
    REQUIRE(StoredMatrix(storage, "K1") == calibration.left.K);
    REQUIRE(StoredMatrix(storage, "K2") == calibration.right.K);
    REQUIRE(StoredMatrix(storage, "D1") ==
            Eigen::Map<const Eigen::RowVectorXd>(calibration.left.distortion.data(), 5));
    REQUIRE(StoredMatrix(storage, "D2") ==
            Eigen::Map<const Eigen::RowVectorXd>(calibration.right.distortion.data(), 8));
    REQUIRE(StoredMatrix(storage, "R") == calibration.R);
    REQUIRE(StoredMatrix(storage, "T") == calibration.T_m);
    REQUIRE(StoredMatrix(storage, "E") == calibration.Essential());
    REQUIRE(StoredMatrix(storage, "F") == calibration.Fundamental());
    cv::Size image_size;
    storage["image_size"] >> image_size;
    REQUIRE(image_size == cv::Size(640, 480));
    REQUIRE(storage["Q"].empty() == !rectified);

    const StereoCalibration read = ReadStereoCalibration(path);
    RequireSameCamera(read.left, calibration.left);
    RequireSameCamera(read.right, calibration.right);
    REQUIRE(read.R == calibration.R);
    REQUIRE(read.T_m == calibration.T_m);
    REQUIRE(read.rectification.has_value() == rectified);
    if (rectified) {
      REQUIRE(StoredMatrix(storage, "P2") == calibration.rectification->P2);
      REQUIRE(read.rectification->R1 == calibration.rectification->R1);
      REQUIRE(read.rectification->R2 == calibration.rectification->R2);
      REQUIRE(read.rectification->P1 == calibration.rectification->P1);
      REQUIRE(read.rectification->P2 == calibration.rectification->P2);
      REQUIRE(read.rectification->Q == calibration.rectification->Q);
    }
  }
}

// E = [T]x R and F = K2^-T E K1^-1 satisfy the epipolar constraint for the
// projections of points seen by both cameras, and F matches the one OpenCV's
// 8-point algorithm estimates from those projections alone.
TEST_CASE("calibration: E and F from a synthetic stereo pair", "[io][unit]") {
  const StereoCalibration calibration = Endoscope();
  const Eigen::Matrix3d E = calibration.Essential(), F = calibration.Fundamental();
  const Eigen::Vector3d T = calibration.T_m;
  Eigen::Matrix3d T_cross;
  T_cross << 0, -T.z(), T.y(), T.z(), 0, -T.x(), -T.y(), T.x(), 0;
  REQUIRE((E - T_cross * calibration.R).norm() < 1e-15);
  // E has two equal singular values |T| and a zero one.
  const Eigen::Vector3d singular = Eigen::JacobiSVD<Eigen::Matrix3d>(E).singularValues();
  REQUIRE(singular(0) == Approx(T.norm()).epsilon(1e-12));
  REQUIRE(singular(1) == Approx(T.norm()).epsilon(1e-12));
  REQUIRE(singular(2) < 1e-15);

  std::mt19937 random(7);
  std::uniform_real_distribution<double> lateral(-0.02, 0.02), depth(0.04, 0.08);
  std::vector<cv::Point2d> left_pixels, right_pixels;
  for (int i = 0; i < 30; ++i) {
    const Eigen::Vector3d X_L(lateral(random), lateral(random), depth(random));
    const Eigen::Vector3d X_R = calibration.R * X_L + T;
    const Eigen::Vector3d x_L = calibration.left.K * X_L / X_L.z();
    const Eigen::Vector3d x_R = calibration.right.K * X_R / X_R.z();
    // Normalised so that the residual is a distance-like number, not one scaled by pixels^2.
    REQUIRE(std::abs(x_R.transpose() * F * x_L) / (F.norm() * x_R.norm() * x_L.norm()) < 1e-14);
    const Eigen::Vector3d y_L = X_L / X_L.z(), y_R = X_R / X_R.z();
    REQUIRE(std::abs(y_R.transpose() * E * y_L) < 1e-15);
    left_pixels.emplace_back(x_L.x(), x_L.y());
    right_pixels.emplace_back(x_R.x(), x_R.y());
  }
  Eigen::Matrix3d F_opencv;
  cv::cv2eigen(cv::findFundamentalMat(left_pixels, right_pixels, cv::FM_8POINT), F_opencv);
  REQUIRE((Normalised(F_opencv) - Normalised(F)).norm() < 1e-5);
}

// Missing or malformed keys are errors naming the file and the key.
TEST_CASE("calibration: errors name the file and the key", "[io][unit]") {
  const std::string path = OutputPath("calibration_bad.yml");
  const StereoCalibration calibration = Endoscope();
  // Written through cv::FileStorage directly, with K2 left out.
  const auto write = [&](const std::function<void(cv::FileStorage&)>& more) {
    cv::FileStorage storage(path, cv::FileStorage::WRITE);
    storage << "K1" << ToMat(calibration.left.K) << "D1" << Distortion(calibration.left);
    storage << "D2" << Distortion(calibration.right) << "R" << ToMat(calibration.R);
    storage << "T" << ToMat(calibration.T_m) << "image_size" << cv::Size(640, 480);
    more(storage);
  };
  write([](cv::FileStorage&) {});
  Error error = ReadError(path);
  REQUIRE(error.where() == path + ": key K2");
  REQUIRE_THAT(error.problem(), Catch::Contains("K2") && Catch::Contains("missing"));

  write([&](cv::FileStorage& storage) { storage << "K2" << cv::Mat::eye(3, 4, CV_64F); });
  error = ReadError(path);
  REQUIRE(error.where() == path + ": key K2");
  REQUIRE_THAT(error.problem(), Catch::Contains("3x4"));

  {
    cv::FileStorage storage(path, cv::FileStorage::WRITE);
    storage << "K1" << ToMat(calibration.left.K) << "D1" << cv::Mat::zeros(1, 14, CV_64F);
    storage << "image_size" << cv::Size(640, 480);
  }
  REQUIRE(ReadError(path).where() == path + ": key D1");

  write([&](cv::FileStorage& storage) {
    storage << "K2" << ToMat(calibration.right.K) << "R1" << cv::Mat::eye(3, 3, CV_64F);
  });
  REQUIRE(ReadError(path).where() == path + ": key R2");

  StereoCalibration skewed = calibration;
  skewed.R(0, 1) += 1e-3;
  WriteStereoCalibration(path, skewed);
  REQUIRE(ReadError(path).where() == path + ": key R");

  const std::string missing = OutputPath("no_such_calibration.yml");
  REQUIRE(ReadError(missing).where() == missing);
}

}  // namespace dg::io
