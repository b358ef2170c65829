#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/calibration.h"
#include "io/scene.h"
#include "stages/register/registration.h"

namespace dg::tools {

// The fiducials followed through a scene's stereo video (capture, grey,
// rectification, FiducialTracker), from their pixels in the first left frame
// (original, distorted), over the frames that start within `window_s`.
// Sightings are in original pixels, in the order of first_uv_left_px.
// `calibration`, when given, receives the scene's calibration as read (its
// image size the video's when the files give none), without the rectification.
// @throws dg::Error for unreadable video or calibration, or a first position
//   outside the calibrated field.
stages::FiducialTracks TrackFiducialsInVideo(const io::Scene& scene, const std::vector<Eigen::Vector2d>& first_uv_left_px,
                                             double window_s, io::StereoCalibration* calibration = nullptr);


}  // namespace dg::tools
