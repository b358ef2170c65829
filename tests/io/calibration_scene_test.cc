// A scene whose calibration is OpenCV's stereo_calib pair of files (no image
// size, T in millimetres): the graph built from it takes the size from the
// video and T in metres. The graph is where the calibration and the video
// meet, so this reader test builds one.
#include <filesystem>
#include <fstream>
#include <string>

#include <Eigen/Core>
#include <catch2/catch.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

#include "io/calibration.h"
#include "io/scene.h"
#include "pipeline/scene_graph.h"
#include "sim/error.h"
#include "tests/support/tiny_phantom.h"

namespace dg {
namespace {

namespace fs = std::filesystem;

cv::Mat ToMat(const Eigen::MatrixXd& matrix) {
  cv::Mat mat;
  cv::eigen2cv(matrix, mat);
  return mat;
}

}  // namespace

TEST_CASE("calibration scene: stereo_calib's two files in millimetres, size from the video", "[io][integration]") {
  const io::Scene phantom = io::ReadScene(testing::TinyPhantomDir() + "/scene.yaml");
  const io::StereoCalibration truth = io::ReadStereoCalibration(phantom.calibration);
  const fs::path dir = testing::TinyPhantomDir() + "/stereo_calib";
  fs::create_directories(dir);
  // As OpenCV's stereo_calib sample writes them, with the square size given in millimetres.
  {
    cv::FileStorage intrinsics((dir / "intrinsics.yml").string(), cv::FileStorage::WRITE);
    intrinsics << "M1" << ToMat(truth.left.K)
               << "D1" << cv::Mat(1, truth.left.num_distortion, CV_64F, const_cast<double*>(truth.left.distortion.data()))
               << "M2" << ToMat(truth.right.K)
               << "D2" << cv::Mat(1, truth.right.num_distortion, CV_64F, const_cast<double*>(truth.right.distortion.data()));
    cv::FileStorage extrinsics((dir / "extrinsics.yml").string(), cv::FileStorage::WRITE);
    extrinsics << "R" << ToMat(truth.R) << "T" << ToMat(truth.T_m * 1e3);
  }
  const auto scene_with = [&](const std::string& units) {
    std::ofstream(dir / "scene.yaml") << "mesh: {file: " << phantom.mesh.file << "}\n"
                                      << "calibration: [intrinsics.yml, extrinsics.yml]\n"
                                      << units << "video: {left: " << phantom.video.left
                                      << ", right: " << phantom.video.right << ", fps: " << phantom.video.fps << "}\n";
    return io::ReadScene((dir / "scene.yaml").string());
  };

  const pipeline::SceneGraph built = pipeline::BuildSceneGraph(scene_with("calibration_units: mm\n"), {});
  REQUIRE(built.calibration.left.width == truth.left.width);  // the video's, as the phantom calibrated it
  REQUIRE(built.calibration.left.height == truth.left.height);
  REQUIRE(built.calibration.left.K == truth.left.K);
  REQUIRE(built.calibration.right.distortion == truth.right.distortion);
  REQUIRE(built.calibration.R == truth.R);
  const double T_error_m = (built.calibration.T_m - truth.T_m).norm();
  CHECK(T_error_m < 1e-18);  // millimetres and back: an ulp or two of a 5 mm baseline

  // Without calibration_units, T in millimetres is refused before a frame is read.
  REQUIRE_THROWS_WITH(pipeline::BuildSceneGraph(scene_with(""), {}),
                      Catch::Contains("T is probably in millimetres") && Catch::Contains("extrinsics.yml: key T"));
  fs::remove_all(dir);
}

}  // namespace dg
