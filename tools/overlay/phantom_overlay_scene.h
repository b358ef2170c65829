#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "io/calibration.h"
#include "io/metaimage.h"
#include "io/scene.h"
#include "sim/tet_mesh.h"
#include "stages/overlay/compositor.h"
#include "stages/overlay/surface_overlay.h"
#include "stages/overlay/volume_overlay.h"
#include "tools/phantom/heart_motion.h"

namespace dg::tools {

// The ground truth of one frame of a phantom: positions in the left camera
// frame, and where each camera sees the surface points (distorted pixels).
struct PhantomTruthFrame {
  Eigen::Matrix3Xd surface_C;           // the dense surface material points
  Eigen::Matrix2Xd surface_uv_left_px, surface_uv_right_px;
  std::vector<std::uint8_t> surface_visible_left, surface_visible_right;
  Eigen::Matrix3Xd internal_C;          // chamber centres and poles
};

// A phantom scene (`dynaguide phantom`) loaded for the overlays: the scene's
// mesh, calibration, overlay assets and CT, its ground truth (truth.h5), and
// the phantom's true motion, so that overlays can be drawn and measured
// without a simulation (the simulated nodes replaced by the truth).
class PhantomOverlayScene {
 public:
  // @throws dg::Error if the scene is not a phantom's (no truth, no overlays,
  //   no CT) or a file is malformed.
  explicit PhantomOverlayScene(const std::string& scene_path);

  const io::Scene& scene() const { return scene_; }
  const sim::TetMesh& mesh() const { return mesh_; }
  const io::StereoCalibration& calibration() const { return calibration_; }
  const Eigen::Isometry3d& T_C_S() const { return T_C_S_; }
  int frames() const { return static_cast<int>(states_.size()); }

  // Node positions (scan frame) at video frame j under the phantom's true motion.
  Eigen::Matrix3Xd TrueNodes(int frame) const;
  PhantomTruthFrame Truth(int frame) const;
  const Eigen::Matrix3Xd& surface_points_S() const { return surface_points_S_; }
  const Eigen::Matrix3Xd& internal_points_S() const { return internal_points_S_; }
  // Left video frame j (CV_8UC3). @throws dg::Error if the video is shorter.
  cv::Mat LeftFrame(int frame) const;

  // The three overlays of the scene, as a run builds them.
  std::unique_ptr<stages::overlay::SurfaceOverlay> MakeMeshOverlay(
      const stages::overlay::SurfaceOverlay::Options& options) const;
  std::unique_ptr<stages::overlay::SurfaceOverlay> MakeTextureOverlay(
      const stages::overlay::SurfaceOverlay::Options& options) const;
  std::unique_ptr<stages::overlay::VolumeOverlay> MakeVolumeOverlay(
      const stages::overlay::VolumeOverlay::Options& options) const;
  stages::overlay::LensView LeftView() const;
  stages::overlay::LensView RightView() const;  // the right camera at the truth's pose (RightLensView)

 private:
  io::Scene scene_;
  sim::TetMesh mesh_;
  io::StereoCalibration calibration_;
  Eigen::Isometry3d T_C_S_;
  std::unique_ptr<phantom::HeartMotion> motion_;
  std::vector<phantom::MotionState> states_;
  Eigen::Matrix3Xd surface_points_S_, internal_points_S_;
  // truth.h5's per-frame datasets, frame-major as stored.
  std::vector<double> surface_xyz_C_, surface_uv_left_, surface_uv_right_, internal_xyz_C_;
  std::vector<std::uint8_t> surface_visible_left_, surface_visible_right_;
};

}  // namespace dg::tools
