// The overlays on the phantom with the simulated nodes replaced by the
// phantom's true motion: embedded internal features project where the truth
// does, the surface overlay error is far below a pixel, in the left eye and in
// the right (a stereo run's), and each overlay mode writes a PNG.
#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>

#include "sim/embedding.h"
#include "stages/camera_model.h"
#include "stages/overlay/overlay_error.h"
#include "tools/overlay/overlay_snapshots.h"
#include "tools/overlay/phantom_overlay_scene.h"
#include "tests/support/temporary_folder.h"
#include "tests/support/tiny_phantom.h"

namespace dg::tools {
namespace {

namespace overlay = stages::overlay;

// The tiny preset, generated once per test process (processes run concurrently).
std::string TinyScene() { return dg::testing::TinyPhantomDir() + "/scene.yaml"; }

// Only the embedding's piecewise-linear interpolation of the smooth motion
// separates the overlay from the truth here (the simulation is bypassed).
TEST_CASE("overlay on the phantom: true motion puts features within 0.5 px, the surface within 0.2 px",
          "[tools][integration]") {
  const PhantomOverlayScene scene(TinyScene());
  const io::CameraCalibration& left = scene.calibration().left;
  const sim::Embedding surface(scene.mesh(), scene.surface_points_S());
  const sim::Embedding internal(scene.mesh(), scene.internal_points_S());
  REQUIRE(surface.num_outside() > 0);  // surface points beyond the mesh's chords are extrapolated
  REQUIRE(surface.max_outside_distance_m() < 1e-3);
  std::vector<double> surface_px, internal_px;
  int measured = 0;
  for (int j = 0; j < scene.frames(); ++j) {
    const Eigen::Matrix3Xd nodes = scene.TrueNodes(j);
    const PhantomTruthFrame truth = scene.Truth(j);
    const overlay::SurfaceOverlayError error = overlay::MeasureSurfaceOverlayError(
        left, scene.T_C_S() * surface.Rebuild(nodes), truth.surface_uv_left_px, truth.surface_C,
        truth.surface_visible_left);
    surface_px.insert(surface_px.end(), error.error_px.begin(), error.error_px.end());
    measured += static_cast<int>(error.points.size());
    const Eigen::Matrix3Xd internal_C = scene.T_C_S() * internal.Rebuild(nodes);
    for (Eigen::Index p = 0; p < internal_C.cols(); ++p)
      internal_px.push_back((stages::Project(left, internal_C.col(p)) - stages::Project(left, truth.internal_C.col(p))).norm());
  }
  const overlay::ErrorSummary s = overlay::Summarize(surface_px), i = overlay::Summarize(internal_px);
  INFO("surface: " << s.count << " points, median " << s.median << " px, max " << s.max << " px; internal: median "
                   << i.median << " px, max " << i.max << " px");
  REQUIRE(measured > 30 * 300);  // most of the side facing the camera, every frame
  REQUIRE(s.max < 0.2);
  REQUIRE(i.max < 0.5);
}

// A stereo run's right eye: the embedded points drawn through the right
// camera's lens at T_R_S = T_R_C T_C_S (RightLensView, as the overlay branches
// build it) land where the phantom's renderer saw them in the right image
// (truth.h5's uv_right_px), within the left eye's bounds. Drawn pixels are the
// rasterizer's: the pinhole projection of the lens-moved vertices.
TEST_CASE("overlay on the phantom: the right eye puts features within 0.5 px, the surface within 0.2 px",
          "[tools][integration]") {
  const PhantomOverlayScene scene(TinyScene());
  const io::StereoCalibration& calibration = scene.calibration();
  const overlay::LensView right = scene.RightView();
  const auto drawn_px = [&](const Eigen::Vector3d& v) {
    const stages::render::PinholeCamera& pinhole = right.pinhole();
    return Eigen::Vector2d(pinhole.fx * v.x() / v.z() + pinhole.cx, pinhole.fy * v.y() / v.z() + pinhole.cy);
  };
  // X_R = R X_C + T (the stereo calibration's convention), for the internal features' true pixels.
  const auto to_right = [&](const Eigen::Vector3d& X_C) -> Eigen::Vector3d { return calibration.R * X_C + calibration.T_m; };
  const sim::Embedding surface(scene.mesh(), scene.surface_points_S());
  const sim::Embedding internal(scene.mesh(), scene.internal_points_S());
  std::vector<double> surface_px, internal_px;
  Eigen::Matrix3Xd surface_view, internal_view;
  for (int j = 0; j < scene.frames(); ++j) {
    const Eigen::Matrix3Xd nodes = scene.TrueNodes(j);
    const PhantomTruthFrame truth = scene.Truth(j);
    right.ToView(surface.Rebuild(nodes), &surface_view);
    for (Eigen::Index p = 0; p < surface_view.cols(); ++p) {
      if (truth.surface_visible_right[p])
        surface_px.push_back((drawn_px(surface_view.col(p)) - truth.surface_uv_right_px.col(p)).norm());
    }
    right.ToView(internal.Rebuild(nodes), &internal_view);
    for (Eigen::Index p = 0; p < internal_view.cols(); ++p) {
      const Eigen::Vector2d true_px = stages::Project(calibration.right, to_right(truth.internal_C.col(p)));
      internal_px.push_back((drawn_px(internal_view.col(p)) - true_px).norm());
    }
  }
  const overlay::ErrorSummary s = overlay::Summarize(surface_px), i = overlay::Summarize(internal_px);
  INFO("right eye surface: " << s.count << " points, median " << s.median << " px, max " << s.max
                             << " px; internal: median " << i.median << " px, max " << i.max << " px");
  REQUIRE(s.count > 30 * 300);  // most of the side facing the camera, every frame
  REQUIRE(s.max < 0.2);
  REQUIRE(i.max < 0.5);
}

// Written, readable, and drawn: each mode's picture differs from the plain frame.
// (What it looks like is for a person to judge.)
TEST_CASE("overlay on the phantom: each mode writes a PNG", "[tools][integration]") {
  const dg::testing::TemporaryFolder folder("dg_overlay_test_png");
  OverlaySnapshotOptions options;
  options.scene = TinyScene();
  options.out_dir = folder.path();
  const OverlaySnapshotSummary summary = WriteOverlaySnapshots(options);
  REQUIRE(summary.files.size() == 8);
  const cv::Mat video = cv::imread(options.out_dir + "/video.png");
  REQUIRE(video.size() == cv::Size(160, 120));
  for (const std::string name : {"mesh", "mesh_inverse_realism", "volume", "volume_inverse_realism", "texture", "composite"}) {
    const cv::Mat image = cv::imread(options.out_dir + "/" + name + ".png");
    INFO(name);
    REQUIRE(image.size() == video.size());
    REQUIRE(cv::norm(image, video, cv::NORM_L1) > 160 * 120);  // on average over a grey level per pixel
  }
  REQUIRE(summary.surface_px.max < 0.2);
}

}  // namespace
}  // namespace dg::tools
