// Live cardiac phase (stages/register/phase_tracker.h) on default phantoms
// against their truth: the fiducials' true positions (truth.h5
// /fiducials/xyz_C_m) seen through the phantom's rectified stereo pair with
// the tracker's pixel error, and the true phase from the truth's /cycles.
// The constant-shift baseline is the best single shift over the
// registration window (two cycles), the most a registration can give.
#include <cmath>
#include <random>

#include <catch2/catch.hpp>

#include "io/calibration.h"
#include "io/h5_file.h"
#include "io/scene.h"
#include "stages/rectify.h"
#include "stages/register/fiducial_motion.h"
#include "stages/register/phase_tracker.h"
#include "tests/support/temporary_folder.h"
#include "tools/phantom/phantom_generator.h"

namespace dg::stages {
namespace {

constexpr double kNoisePx = 0.3;  // the fiducial tracker's error on the default phantom: 0.1-0.3 px
constexpr double kWindowCycles = 2;

struct Truth {
  FiducialMotion scan;
  io::StereoCalibration calibration;
  Eigen::Isometry3d T_C_S;
  double fps = 0, period_s = 0, phase_shift_s = 0;
  std::vector<double> starts_s, periods_s;
  io::H5Shape xyz_shape;
  std::vector<double> xyz_C_m;  // [frame][fiducial][3]
  int frames() const { return static_cast<int>(xyz_shape[0]); }
  double TruePhase(int frame) const { return CyclePhase(starts_s, periods_s, frame / fps + phase_shift_s); }
};

Truth MakePhantom(double period_variation, double amplitude_variation, std::uint64_t seed) {
  tools::phantom::PhantomSpec spec = tools::phantom::PresetSpec("default");
  spec.seed = seed;
  spec.period_variation = period_variation;
  spec.amplitude_variation = amplitude_variation;
  const testing::TemporaryFolder folder("dg_phase_test");
  tools::phantom::GeneratePhantom(spec, folder.path(), false);
  const io::Scene scene = io::ReadScene(folder.File("scene.yaml"));
  Truth truth;
  truth.scan = ReadFiducialMotion(scene.preoperative->motion);
  truth.calibration = io::ReadStereoCalibration(scene.calibration);
  truth.calibration.rectification = ComputeRectification(truth.calibration, /*alpha=*/0);  // as the run's rectify stage
  const io::H5Reader file(scene.truth);
  truth.T_C_S.matrix() = file.ReadMatrix("/T_C_S");
  truth.fps = file.ReadScalar("/fps");
  truth.period_s = file.ReadScalar("/period_s");
  truth.phase_shift_s = file.ReadScalar("/phase_shift_s");
  io::H5Shape shape;
  truth.starts_s = file.Read<double>("/cycles/start_s", &shape);
  truth.periods_s = file.Read<double>("/cycles/period_s", &shape);
  truth.xyz_C_m = file.Read<double>("/fiducials/xyz_C_m", &truth.xyz_shape);
  return truth;
}

struct PhaseErrors {
  double live_mean_ms = 0, live_max_ms = 0, constant_mean_ms = 0, constant_max_ms = 0;
  double sigma_ms_median = 0, live_rms_ms = 0;
  double live_vs_constant_mean_ms = 0;
};

// Tracks the phase from the window's end to the video's end.
PhaseErrors TrackPhase(const Truth& truth, std::uint64_t noise_seed) {
  const int window = static_cast<int>(std::ceil(kWindowCycles * truth.period_s * truth.fps));
  // The best constant shift over the window: the true phase's mean offset from t / T there.
  double offset_sum = 0;
  for (int j = 0; j < window; ++j) {
    offset_sum += PhaseDifference(truth.TruePhase(j), j / truth.fps / truth.period_s);
  }
  const double constant_phase_at_zero = offset_sum / window;
  const auto constant_phase = [&](int j) { return constant_phase_at_zero + j / truth.fps / truth.period_s; };

  const Triangulator geometry(truth.calibration);
  PhaseTracker tracker({}, truth.scan, geometry, truth.period_s);
  std::mt19937_64 rng(noise_seed);
  std::normal_distribution<double> noise(0.0, kNoisePx);
  const int F = static_cast<int>(truth.xyz_shape[1]);
  PhaseErrors errors;
  std::vector<double> sigmas;
  int counted = 0;
  for (int j = 0; j < truth.frames(); ++j) {
    std::vector<RectifiedSighting> sightings(F);
    for (int i = 0; i < F; ++i) {
      const Eigen::Vector3d X_C = Eigen::Map<const Eigen::Vector3d>(&truth.xyz_C_m[(size_t(j) * F + i) * 3]);
      sightings[i].valid = true;
      sightings[i].uvd_px = geometry.ToRectifiedDisparity(X_C) + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    }
    tracker.Observe(j / truth.fps, sightings);
    if (j + 1 < window) continue;
    if (!tracker.started()) tracker.Start(truth.T_C_S, j / truth.fps, constant_phase(j), 1 / truth.period_s);
    const PhaseEstimate estimate = tracker.Estimate();
    REQUIRE(estimate.valid);
    const double live_ms = std::abs(PhaseDifference(estimate.phase, truth.TruePhase(j))) * 1e3 * truth.period_s;
    const double constant_ms = std::abs(PhaseDifference(constant_phase(j), truth.TruePhase(j))) * 1e3 * truth.period_s;
    errors.live_mean_ms += live_ms;
    errors.live_rms_ms += live_ms * live_ms;
    errors.live_max_ms = std::max(errors.live_max_ms, live_ms);
    errors.constant_mean_ms += constant_ms;
    errors.constant_max_ms = std::max(errors.constant_max_ms, constant_ms);
    errors.live_vs_constant_mean_ms +=
        std::abs(PhaseDifference(estimate.phase, constant_phase(j))) * 1e3 * truth.period_s;
    sigmas.push_back(estimate.sigma * 1e3 * truth.period_s);
    ++counted;
  }
  errors.live_mean_ms /= counted;
  errors.live_rms_ms = std::sqrt(errors.live_rms_ms / counted);
  errors.constant_mean_ms /= counted;
  errors.live_vs_constant_mean_ms /= counted;
  std::nth_element(sigmas.begin(), sigmas.begin() + sigmas.size() / 2, sigmas.end());
  errors.sigma_ms_median = sigmas[sigmas.size() / 2];
  return errors;
}

TEST_CASE("phase tracker: an irregular beat is followed closer than by a constant shift", "[phase][integration]") {
  const std::uint64_t seed = GENERATE(3, 17);
  const Truth truth = MakePhantom(0.10, 0.06, seed);
  const PhaseErrors errors = TrackPhase(truth, seed);
  UNSCOPED_INFO("seed " << seed << ": live mean " << errors.live_mean_ms << " ms, max " << errors.live_max_ms
                        << " ms; constant shift mean " << errors.constant_mean_ms << " ms, max "
                        << errors.constant_max_ms << " ms; median sigma " << errors.sigma_ms_median << " ms");
  // Measured (0.3 px): live 2.0 / 7.0 ms (seed 3), 2.4 / 10.1 ms (seed 17),
  // mean / max, against 28 / 42 and 52 / 114 ms for the constant shift. The
  // mean is held to the product's 3 ms; the max to 1.5 times the worst seen
  // (the product's aim is 10 ms: see docs/phase.md).
  CHECK(errors.live_mean_ms < errors.constant_mean_ms / 5);
  CHECK(errors.live_mean_ms <= 3.0);
  CHECK(errors.live_max_ms <= 15.0);
  // The reported sigma is honest: the errors' rms over the median sigma (1.0
  // when honest; measured 1.1-1.3) within a factor of two.
  CHECK(errors.live_rms_ms / errors.sigma_ms_median == Approx(1.0).margin(0.5));
}

TEST_CASE("phase tracker: a regular beat agrees with the constant shift", "[phase][integration]") {
  const Truth truth = MakePhantom(0.0, 0.0, 5);
  const PhaseErrors errors = TrackPhase(truth, 5);
  UNSCOPED_INFO("live mean " << errors.live_mean_ms << " ms, max " << errors.live_max_ms << " ms; against the shift "
                             << errors.live_vs_constant_mean_ms << " ms; median sigma " << errors.sigma_ms_median);
  // Measured: 1.7 ms mean apart (the live estimate's own noise; the shift is exact here).
  CHECK(errors.live_vs_constant_mean_ms <= 3.4);
}

}  // namespace
}  // namespace dg::stages
