#include "tests/stages/track/rectified_phantom.h"

#include <Eigen/Core>
#include <catch2/catch.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "io/h5_file.h"
#include "stages/rectify.h"
#include "tools/phantom/phantom_generator.h"

namespace dg::stages::testing {
namespace {

std::vector<cv::Mat> ReadGrey(const std::string& path, const cv::Mat& map_x, const cv::Mat& map_y) {
  cv::VideoCapture capture(path);
  REQUIRE(capture.isOpened());
  std::vector<cv::Mat> frames;
  for (cv::Mat frame, grey; capture.read(frame);) {
    cv::cvtColor(frame, grey, cv::COLOR_BGR2GRAY);
    cv::Mat rectified;  // a new buffer per frame: remap would reuse one of the same size
    cv::remap(grey, rectified, map_x, map_y, cv::INTER_LINEAR);
    frames.push_back(rectified);
  }
  return frames;
}

}  // namespace

void GeneratePhantomScene(double duration_s, const std::string& dir) {
  tools::phantom::PhantomSpec spec = tools::phantom::PresetSpec("default");
  spec.duration_s = duration_s;
  tools::phantom::GeneratePhantom(spec, dir, false);
}

void AddRectification(io::StereoCalibration* calibration) {
  calibration->rectification = ComputeRectification(*calibration, /*alpha=*/0);
}

RectifiedPhantom LoadRectified(const std::string& scene_dir) {
  RectifiedPhantom scene;
  scene.calibration = io::ReadStereoCalibration(scene_dir + "/calibration.yaml");
  AddRectification(&scene.calibration);
  const auto read_eye = [&](const io::CameraCalibration& camera, const Eigen::Matrix3d& R_rect,
                            const Eigen::Matrix<double, 3, 4>& P_rect, const std::string& video) {
    cv::Mat K, R, P, map_x, map_y;
    cv::eigen2cv(camera.K, K);
    cv::eigen2cv(R_rect, R);
    cv::eigen2cv(P_rect, P);
    const cv::Mat D(1, 8, CV_64F, const_cast<double*>(camera.distortion.data()));
    cv::initUndistortRectifyMap(K, D, R, P, cv::Size(camera.width, camera.height), CV_32FC1, map_x, map_y);
    return ReadGrey(scene_dir + "/video/" + video, map_x, map_y);
  };
  const auto& rectification = *scene.calibration.rectification;
  scene.left_R = read_eye(scene.calibration.left, rectification.R1, rectification.P1, "left.avi");
  scene.right_R = read_eye(scene.calibration.right, rectification.R2, rectification.P2, "right.avi");
  REQUIRE(scene.left_R.size() == scene.right_R.size());
  return scene;
}

TruthTracks ReadTruth(const std::string& scene_dir, const std::string& group) {
  const io::H5Reader truth(scene_dir + "/truth.h5");
  io::H5Shape shape;
  const std::vector<double> uv_left = truth.Read<double>(group + "/uv_left_px", &shape);
  const std::vector<double> uv_right = truth.Read<double>(group + "/uv_right_px");
  const std::vector<double> xyz = truth.Read<double>(group + "/xyz_C_m");
  const std::vector<std::uint8_t> visible_left = truth.Read<std::uint8_t>(group + "/visible_left");
  const std::vector<std::uint8_t> visible_right = truth.Read<std::uint8_t>(group + "/visible_right");
  const size_t frames = shape[0], points = shape[1];
  TruthTracks tracks;
  tracks.uv_left_px.resize(frames);
  tracks.uv_right_px.resize(frames);
  tracks.xyz_C_m.resize(frames);
  tracks.visible_left.resize(frames);
  tracks.visible_right.resize(frames);
  for (size_t f = 0; f < frames; ++f) {
    for (size_t p = 0; p < points; ++p) {
      const size_t i = f * points + p;
      tracks.uv_left_px[f].emplace_back(uv_left[2 * i], uv_left[2 * i + 1]);
      tracks.uv_right_px[f].emplace_back(uv_right[2 * i], uv_right[2 * i + 1]);
      tracks.xyz_C_m[f].emplace_back(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
      tracks.visible_left[f].push_back(visible_left[i] != 0);
      tracks.visible_right[f].push_back(visible_right[i] != 0);
    }
  }
  return tracks;
}

}  // namespace dg::stages::testing
