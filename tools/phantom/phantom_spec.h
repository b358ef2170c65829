#pragma once

#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "sim/material.h"

namespace dg::tools::phantom {

// Everything `dynaguide phantom` makes is set here; a preset fills it and
// command-line options override single fields. Lengths in metres, times in seconds.
struct PhantomSpec {
  std::string preset = "default";
  uint64_t seed = 1;

  // Geometry: an ellipsoid standing on the mount plane z = 0 of the scan frame S.
  Eigen::Vector3d semi_axes_m{0.022, 0.018, 0.030};
  double centre_height_m = 0.018;
  int tets = 8000;

  // Motion (see heart_motion.h): the nominal cycle and its cycle-to-cycle variation.
  double heart_rate_bpm = 90;
  double radial_contraction = 0.12;     // fractional radius change at the top at peak systole
  double twist_rad = 0.15;              // twist about the long axis at the top at peak systole
  double longitudinal_shortening = 0.08;
  Eigen::Vector2d sway_m{0.0015, 0.0010};
  double amplitude_variation = 0.06;    // standard deviation of each cycle's amplitude factor
  double period_variation = 0.04;       // standard deviation of each cycle's period factor
  // An early beat every N cycles (0: none): a premature contraction that
  // comes after kPrematurePeriodFactor of its period, followed by a
  // compensatory pause (the next cycle longer by as much), as an ectopic
  // beat interrupts a sinus rhythm.
  int premature_beat_every = 0;
  static constexpr double kPrematurePeriodFactor = 0.65;

  // Preoperative 4D CT of the nominal cycle.
  int phases = 20;
  double voxel_m = 1.0e-3;
  double ct_noise_hu = 15;
  int fiducials = 6;
  // Which files hold the CT: "mhd" (ct/phase_NN.mhd), "dicom" (a series per
  // phase under ct/dicom/phase_NN/) or "both".
  std::string ct_format = "both";
  bool writes_metaimage() const { return ct_format != "dicom"; }
  bool writes_dicom() const { return ct_format != "mhd"; }

  // Stereo endoscope and video.
  int width = 640, height = 480;
  double fps = 30;
  double duration_s = 3.5;              // at 90 bpm: over five cycles
  double baseline_m = 0.005;
  double working_distance_m = 0.060;
  double sensor_noise = 2.0;            // standard deviation, 8-bit grey levels
  // Lossless either way: "raw" (uncompressed AVI, as a frame grabber records,
  // nothing to decode; about 0.9 MB a 640x480 frame) or "huffyuv" (about
  // 0.5 MB a frame, 3.5-4.5 ms of one core to decode each eye).
  std::string video_codec = "raw";
  int supersample = 2;
  int chessboard_pairs = 16;

  // The tissue model a scene simulates with.
  sim::Material material{3.0e3, 0.45, 1.0e3};

  double period_s() const { return 60.0 / heart_rate_bpm; }
  double height_m() const { return centre_height_m + semi_axes_m.z(); }

  // Empty when valid; otherwise which field is wrong and why.
  std::string Validate() const;
};

// "default", "tiny" (small images and mesh, 1 s: for tests), "stiff" (a stiffer,
// nearly incompressible material) or "extreme" (large, fast motion).
// @throws dg::Error for an unknown name, listing the known ones.
PhantomSpec PresetSpec(const std::string& name);

}  // namespace dg::tools::phantom
