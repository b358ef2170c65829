#include "tools/register/truth_tracks.h"

#include <algorithm>
#include <random>

#include "io/h5_file.h"
#include "sim/error.h"

namespace dg::tools {

RegistrationTruth ReadRegistrationTruth(const std::string& truth_h5) {
  const io::H5Reader file(truth_h5);
  RegistrationTruth truth;
  truth.T_C_S = file.ReadMatrix("/T_C_S");
  truth.phase_shift_s = file.ReadScalar("/phase_shift_s");
  truth.period_s = file.ReadScalar("/period_s");
  truth.fps = file.ReadScalar("/fps");
  io::H5Shape shape, visible_shape;
  const std::vector<double> left = file.Read<double>("/fiducials/uv_left_px", &shape);
  const std::vector<double> right = file.Read<double>("/fiducials/uv_right_px");
  const std::vector<std::uint8_t> visible_left = file.Read<std::uint8_t>("/fiducials/visible_left", &visible_shape);
  const std::vector<std::uint8_t> visible_right = file.Read<std::uint8_t>("/fiducials/visible_right");
  if (shape.size() != 3 || shape[2] != 2 || visible_shape != io::H5Shape{shape[0], shape[1]} ||
      right.size() != left.size() || visible_right.size() != visible_left.size() || !(truth.fps > 0)) {
    throw Error("the fiducials' truth must be uv_{left,right}_px [frames, fiducials, 2] and visible_* [frames, fiducials]",
                truth_h5 + ":/fiducials", "regenerate the phantom with dynaguide phantom");
  }
  for (size_t j = 0; j < shape[0]; ++j) {
    truth.tracks.t_s.push_back(j / truth.fps);
    std::vector<stages::FiducialSighting> frame(shape[1]);
    for (size_t i = 0; i < shape[1]; ++i) {
      const size_t row = j * shape[1] + i;
      frame[i].in_left = visible_left[row];
      frame[i].in_right = visible_right[row];
      frame[i].uv_left_px = {left[2 * row], left[2 * row + 1]};
      frame[i].uv_right_px = {right[2 * row], right[2 * row + 1]};
    }
    truth.tracks.frames.push_back(std::move(frame));
  }
  return truth;
}

stages::FiducialTracks FirstFrames(const stages::FiducialTracks& tracks, int frames) {
  const size_t n = std::min(tracks.t_s.size(), static_cast<size_t>(std::max(0, frames)));
  return {{tracks.t_s.begin(), tracks.t_s.begin() + n}, {tracks.frames.begin(), tracks.frames.begin() + n}};
}

void CorruptTracks(stages::FiducialTracks* tracks, double sigma_px, double outlier_fraction, double outlier_reach_px,
                   std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma_px);
  std::uniform_real_distribution<double> unit(0.0, 1.0), offset(-outlier_reach_px, outlier_reach_px);
  auto corrupt = [&](Eigen::Vector2d* uv) {
    if (unit(rng) < outlier_fraction) {
      Eigen::Vector2d shift;
      do shift = {offset(rng), offset(rng)};
      while (shift.norm() < 20);
      *uv += shift;
    } else {
      *uv += Eigen::Vector2d(noise(rng), noise(rng));
    }
  };
  for (auto& frame : tracks->frames) {
    for (stages::FiducialSighting& s : frame) {
      corrupt(&s.uv_left_px);
      corrupt(&s.uv_right_px);
    }
  }
}

}  // namespace dg::tools
