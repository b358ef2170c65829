#include "tools/register/video_fiducials.h"

#include "io/calibration.h"
#include "sim/error.h"
#include "stages/capture.h"
#include "stages/rectify.h"
#include "stages/register/registration_stage.h"
#include "stages/track/fiducial_tracker.h"
#include "stages/track/triangulator.h"

namespace dg::tools {
namespace {

// Endoscopic fiducials lie a few centimetres away: the stereo search's depth range.
constexpr double kNear_m = 0.03, kFar_m = 0.30;

}  // namespace

stages::FiducialTracks TrackFiducialsInVideo(const io::Scene& scene, const std::vector<Eigen::Vector2d>& first_uv_left_px,
                                             double window_s, io::StereoCalibration* calibration_read) {
  stages::CaptureStage::Options capture_options;
  capture_options.left_path = scene.video.left;
  capture_options.right_path = scene.video.right;
  capture_options.fps = scene.video.fps;
  stages::CaptureStage capture(capture_options);
  io::StereoCalibration calibration =
      io::ReadStereoCalibration(scene.calibration, io::ImageSize{capture.size().width, capture.size().height});
  if (calibration_read) *calibration_read = calibration;
  const stages::RectifyStage rectify(stages::RectifyStage::Options{}, calibration);
  calibration.rectification = rectify.rectification();
  const stages::Triangulator geometry(calibration);

  stages::FiducialTracker tracker = stages::StartFiducialTracker(geometry, first_uv_left_px, kNear_m, kFar_m);

  stages::FiducialTracks tracks;
  while (std::optional<stages::StereoFrame> frame = capture.Next()) {
    // Frames starting within the window (to a microsecond: periods are given rounded).
    if (!tracks.t_s.empty() && frame->t_s - tracks.t_s.front() >= window_s - 1e-6) break;
    stages::ConvertToGrey(frame->left, frame->left);
    stages::ConvertToGrey(frame->right, frame->right);
    const stages::RectifiedPair pair = rectify.Process(*frame);
    std::vector<stages::FiducialSighting> sightings;
    for (const stages::FiducialObservation& seen : tracker.Process(pair.left, pair.right)) {
      sightings.push_back(stages::SightingFromRectified(seen, geometry));
    }
    tracks.t_s.push_back(frame->t_s);
    tracks.frames.push_back(std::move(sightings));
  }
  return tracks;
}

}  // namespace dg::tools
