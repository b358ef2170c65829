#include "stages/preop/motion/motion_registration.h"

#include <cmath>
#include <utility>
#include <numbers>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include "sim/error.h"

namespace dg::stages::preop {
namespace {

using Catch::Matchers::Contains;

// A smooth displacement field (metres) with a known Jacobian: a sinusoidal
// swirl of amplitude 1.5 mm over a 48 mm cube centred at the origin.
Eigen::Vector3d KnownDisplacement(const Eigen::Vector3d& X) {
  constexpr double kAmplitude_m = 1.5e-3, kLength_m = 0.048;
  const Eigen::Vector3d phase = X * std::numbers::pi / kLength_m;
  return kAmplitude_m * Eigen::Vector3d(std::sin(phase.y() + 0.3), std::cos(phase.z()), std::sin(phase.x() - 0.2));
}

// A textured object: blobs of different HU at several scales, so that every
// region of the image constrains the motion.
double TexturedHu(const Eigen::Vector3d& x) {
  const Eigen::Vector3d mm = x * 1000;
  return 200 * std::sin(mm.x() / 3.1) * std::sin(mm.y() / 2.7 + 1) * std::sin(mm.z() / 3.4 + 2) +
         400 * std::exp(-(mm - Eigen::Vector3d(5, -4, 3)).squaredNorm() / 60) -
         300 * std::exp(-(mm - Eigen::Vector3d(-7, 6, -5)).squaredNorm() / 40);
}

// A 48 mm cube of voxel_mm voxels centred at the origin; fixed when warped,
// so that fixed(X) = moving(X + u(X)) and the registration's answer is u.
io::CtImage TexturedCube(bool warped, double voxel_mm = 1.5) {
  io::CtImage image;
  image.size = Eigen::Vector3i::Constant(static_cast<int>(std::lround(48 / voxel_mm)) + 1);
  image.spacing_m = Eigen::Vector3d::Constant(voxel_mm * 1e-3);
  image.origin_m = Eigen::Vector3d::Constant(-0.024);
  image.source = warped ? "fixed (warped)" : "moving";
  image.values.resize(image.num_voxels());
  for (int k = 0; k < image.size.z(); ++k) {
    for (int j = 0; j < image.size.y(); ++j) {
      for (int i = 0; i < image.size.x(); ++i) {
        const Eigen::Vector3d X = image.PointOf(i, j, k);
        image.values[image.Index(i, j, k)] = static_cast<float>(TexturedHu(warped ? X + KnownDisplacement(X) : X));
      }
    }
  }
  return image;
}

MotionRegistrationOptions AnalyticOptions() {
  MotionRegistrationOptions options;
  options.grid_spacing_mm = 12;
  options.levels = 2;
  options.max_iterations = 60;
  return options;
}

// Points every 3 mm in the box [lo, hi] (metres).
Eigen::Matrix3Xd PointsIn(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  Eigen::Matrix3Xd points(3, 0);
  for (double x = lo.x(); x <= hi.x() + 1e-4; x += 0.003) {
    for (double y = lo.y(); y <= hi.y() + 1e-4; y += 0.003) {
      for (double z = lo.z(); z <= hi.z() + 1e-4; z += 0.003) {
        points.conservativeResize(3, points.cols() + 1);
        points.col(points.cols() - 1) = Eigen::Vector3d(x, y, z);
      }
    }
  }
  return points;
}

// Mean and max of |u - KnownDisplacement| over the points, mm.
std::pair<double, double> ErrorsMm(const PhaseDeformation& deformation, const Eigen::Matrix3Xd& points) {
  const Eigen::Matrix3Xd u = deformation.Displacements(points);
  double sum_mm = 0, max_mm = 0;
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    const double error_mm = (u.col(i) - KnownDisplacement(points.col(i))).norm() * 1000;
    sum_mm += error_mm;
    max_mm = std::max(max_mm, error_mm);
  }
  return {sum_mm / points.cols(), max_mm};
}

// A CT warped by a known smooth displacement: the registration recovers it
// inside the image (away from the border, where samples leave the moving image).
TEST_CASE("motion registration: recovers a known smooth displacement", "[unit]") {
  const std::vector<io::CtImage> phases = {TexturedCube(true), TexturedCube(false)};
  const std::vector<PhaseDeformation> deformations = RegisterPhases(phases, AnalyticOptions());
  REQUIRE(deformations.size() == 2);

  const Eigen::Matrix3Xd points = PointsIn(Eigen::Vector3d::Constant(-0.015), Eigen::Vector3d::Constant(0.015));
  const auto [mean_mm, max_mm] = ErrorsMm(deformations[1], points);
  INFO("mean " << mean_mm << " mm, max " << max_mm << " mm over " << points.cols() << " points");
  CHECK(mean_mm < 0.06);
  CHECK(max_mm < 0.2);

  // The swirl's Jacobian determinant lies within 1 +- 0.3 (|du/dx| <= 0.1 per
  // entry): the fitted spline's over the image must too, and be positive.
  const PhaseRegistrationReport& report = deformations[1].report();
  CHECK(report.min_jacobian > 0.7);
  CHECK(report.max_jacobian < 1.3);
  CHECK(report.metric_after < 0.05 * report.metric_before);
  CHECK(report.iterations > 0);
  CHECK(deformations[0].Displacements(points).isZero());
}

// A fine scan (0.75 mm voxels) is compared at finest_sample_mm (every fourth
// voxel, after a blur of two): the motion comes out within a tenth of a
// millimetre from a sixty-fourth of the samples. These noise-free images
// reward every voxel (0.013 / 0.031 mm), which a CT's noise does not.
TEST_CASE("motion registration: a fine scan sampled at finest_sample_mm recovers the motion", "[unit]") {
  const std::vector<io::CtImage> phases = {TexturedCube(true, 0.75), TexturedCube(false, 0.75)};
  const Eigen::Matrix3Xd points = PointsIn(Eigen::Vector3d::Constant(-0.015), Eigen::Vector3d::Constant(0.015));
  MotionRegistrationOptions options = AnalyticOptions();
  options.finest_sample_mm = 3;
  const auto [sampled_mean_mm, sampled_max_mm] = ErrorsMm(RegisterPhases(phases, options)[1], points);
  options.finest_sample_mm = 0.75;
  const auto [every_mean_mm, every_max_mm] = ErrorsMm(RegisterPhases(phases, options)[1], points);
  INFO("every voxel: mean " << every_mean_mm << " mm, max " << every_max_mm << " mm; sampled at 3 mm: mean "
                            << sampled_mean_mm << " mm, max " << sampled_max_mm << " mm");
  CHECK(sampled_mean_mm < 0.07);
  CHECK(sampled_max_mm < 0.2);
  CHECK(every_max_mm < 0.06);
}

// The motion wanted in a corner of the cube only: the registration works on
// the corner's box grown by two control spacings (24 mm here), recovers the
// motion there as the whole grid does, and refuses points beyond its grid.
TEST_CASE("motion registration: a region registers the box around it and is refused beyond", "[unit]") {
  const std::vector<io::CtImage> phases = {TexturedCube(true), TexturedCube(false)};
  MotionRegistrationOptions options = AnalyticOptions();
  options.region_min_S_m = Eigen::Vector3d(-0.015, -0.015, -0.015);
  options.region_max_S_m = Eigen::Vector3d(-0.0035, -0.0005, -0.0065);
  // Voxel i lies at -24 + 1.5 i mm: the box grown by 24 mm spans -39 mm
  // (clamped to voxel 0) to 20.5, 23.5, 17.5 mm, voxels 29.7, 31.7 and 27.7,
  // rounded outwards.
  const io::CtImage grid = RegistrationGrid(phases[0], options);
  CHECK(grid.size == Eigen::Vector3i(31, 33, 29));
  CHECK((grid.origin_m - phases[0].origin_m).norm() < 1e-12);
  CHECK(grid.values.empty());

  const PhaseDeformation deformation = PhaseRegistration(phases, options).Register(1);
  const Eigen::Matrix3Xd points = PointsIn(*options.region_min_S_m, *options.region_max_S_m);
  const auto [mean_mm, max_mm] = ErrorsMm(deformation, points);
  INFO("mean " << mean_mm << " mm, max " << max_mm << " mm over " << points.cols() << " points");
  CHECK(mean_mm < 0.08);
  CHECK(max_mm < 0.15);
  CHECK_THROWS_WITH(deformation.Displacements(Eigen::Vector3d(0.0, 0.0, 0.023)), Contains("outside"));

  options.region_min_S_m = Eigen::Vector3d::Constant(0.1);
  options.region_max_S_m = Eigen::Vector3d::Constant(0.2);
  CHECK_THROWS_WITH(RegistrationGrid(phases[0], options), Contains("misses"));
  options.region_max_S_m.reset();
  CHECK_THROWS_WITH(RegistrationGrid(phases[0], options), Contains("together"));
}

// Each registration is deterministic and independent of the others, so
// phases registered at once must give, to the bit, what one at a time gives;
// an optimiser with process-wide state (ITK's L-BFGS-B) does not. The fine
// control grid makes the optimiser's own work a large share of each
// iteration, so that concurrent optimisers overlap often.
TEST_CASE("motion registration: phases registered at once match one at a time to the bit", "[unit]") {
  const io::CtImage moving = TexturedCube(false);
  const std::vector<io::CtImage> phases = {TexturedCube(true), moving, moving, moving, moving};
  MotionRegistrationOptions options = AnalyticOptions();
  options.levels = 1;
  options.max_iterations = 15;
  options.grid_spacing_mm = 3;
  const Eigen::Matrix3Xd points = Eigen::Matrix3Xd::Random(3, 50) * 0.015;
  const Eigen::Matrix3Xd one_at_a_time = RegisterPhases({phases[0], moving}, options)[1].Displacements(points);
  REQUIRE(one_at_a_time.norm() > 0);
  tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
  std::vector<PhaseDeformation> at_once(phases.size());
  const PhaseRegistration registration(phases, options);
  tbb::parallel_for(1, static_cast<int>(phases.size()), [&](int k) { at_once[k] = registration.Register(k); });
  for (size_t k = 1; k < phases.size(); ++k) {
    INFO("phase " << k);
    CHECK((at_once[k].Displacements(points) - one_at_a_time).cwiseAbs().maxCoeff() == 0.0);
  }
}

TEST_CASE("motion registration: bad input gets named errors", "[unit]") {
  const io::CtImage cube = TexturedCube(false);
  SECTION("one phase") {
    REQUIRE_THROWS_WITH(RegisterPhases({cube}, AnalyticOptions()), Contains("at least two phases"));
  }
  SECTION("phases on different grids") {
    io::CtImage shifted = cube;
    shifted.origin_m.x() += 1e-3;
    shifted.source = "shifted.mhd";
    REQUIRE_THROWS_WITH(RegisterPhases({cube, shifted}, AnalyticOptions()),
                        Contains("phase 1 (shifted.mhd)") && Contains("differs from phase 0"));
  }
  SECTION("a phase that is not one after the first") {
    const std::vector<io::CtImage> phases = {cube, cube};
    const PhaseRegistration registration(phases, AnalyticOptions());
    REQUIRE_THROWS_WITH(registration.Register(0), Contains("phase 0 is not one of phases 1 to 1"));
    REQUIRE_THROWS_WITH(registration.Register(2), Contains("phase 2"));
  }
  SECTION("values that do not fill the grid") {
    io::CtImage short_phase = cube;
    short_phase.values.pop_back();
    REQUIRE_THROWS_WITH(RegisterPhases({cube, short_phase}, AnalyticOptions()), Contains("phase 1"));
  }
  SECTION("invalid options") {
    MotionRegistrationOptions options = AnalyticOptions();
    options.grid_spacing_mm = 0;
    CHECK_THAT(options.Validate(), Contains("grid_spacing_mm"));
    REQUIRE_THROWS_WITH(RegisterPhases({cube, cube}, options), Contains("grid_spacing_mm"));
    options = AnalyticOptions();
    options.levels = 0;
    CHECK_THAT(options.Validate(), Contains("levels"));
    options = AnalyticOptions();
    options.max_iterations = 0;
    CHECK_THAT(options.Validate(), Contains("max_iterations"));
    options = AnalyticOptions();
    options.bending_weight = -1;
    CHECK_THAT(options.Validate(), Contains("bending_weight"));
    CHECK(AnalyticOptions().Validate().empty());
  }
}

TEST_CASE("motion registration: points outside the CT's grid are an error", "[unit]") {
  MotionRegistrationOptions options = AnalyticOptions();
  options.max_iterations = 1;
  const std::vector<PhaseDeformation> deformations =
      RegisterPhases({TexturedCube(true), TexturedCube(false)}, options);
  Eigen::Matrix3Xd points(3, 2);
  points.col(0) = Eigen::Vector3d::Zero();
  points.col(1) = Eigen::Vector3d(0.1, 0, 0);
  REQUIRE_THROWS_WITH(deformations[1].Displacements(points), Contains("point 1") && Contains("outside"));

  // Within a voxel beyond the image's extent (an organ cut by the field of
  // view, its smoothed surface), a point takes the displacement at the
  // extent's nearest point.
  const io::CtImage grid = TexturedCube(true);
  const auto at_index = [&](double i) {
    const Eigen::Vector3d index(i, 0.5 * (grid.size.y() - 1), 0.5 * (grid.size.z() - 1));
    return Eigen::Vector3d(grid.origin_m + grid.direction * grid.spacing_m.cwiseProduct(index));
  };
  const double edge = grid.size.x() - 0.5;
  Eigen::Matrix3Xd beyond(3, 2);
  beyond << at_index(edge - 1e-9), at_index(edge + 0.9);
  const Eigen::Matrix3Xd u = deformations[1].Displacements(beyond);
  CHECK((u.col(1) - u.col(0)).norm() < 1e-12);
  beyond.col(1) = at_index(edge + 1.1);
  CHECK_THROWS_WITH(deformations[1].Displacements(beyond), Contains("outside"));
}

// A cubic B-spline interpolant reproduces cubic polynomials exactly where the
// boundary's mirroring does not reach (its influence decays by 0.27 a voxel),
// so inside an oblique, anisotropic grid the value and gradient must be the
// polynomial's: the registration's moving image and its gradient in S.
TEST_CASE("motion registration: the moving image's interpolant reproduces a cubic in an oblique grid", "[unit]") {
  io::CtImage ct;
  ct.size = Eigen::Vector3i(30, 28, 26);
  ct.spacing_m = Eigen::Vector3d(0.8e-3, 1.1e-3, 1.6e-3);
  ct.origin_m = Eigen::Vector3d(-0.01, 0.004, 0.02);
  ct.direction = (Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized())).toRotationMatrix();
  const auto cubic = [](const Eigen::Vector3d& x_m) {
    const Eigen::Vector3d mm = x_m * 1000;
    return 40 + 3 * mm.x() - 2 * mm.y() + 0.5 * mm.z() + 0.2 * mm.x() * mm.y() - 0.03 * mm.z() * mm.z() * mm.x() +
           0.01 * mm.y() * mm.y() * mm.y();
  };
  const auto cubic_gradient_per_m = [](const Eigen::Vector3d& x_m) -> Eigen::Vector3d {
    const Eigen::Vector3d mm = x_m * 1000;
    return Eigen::Vector3d(3 + 0.2 * mm.y() - 0.03 * mm.z() * mm.z(), -2 + 0.2 * mm.x() + 0.03 * mm.y() * mm.y(),
                           0.5 - 0.06 * mm.z() * mm.x()) * 1000;
  };
  ct.values.resize(ct.num_voxels());
  for (int k = 0; k < ct.size.z(); ++k) {
    for (int j = 0; j < ct.size.y(); ++j) {
      for (int i = 0; i < ct.size.x(); ++i) ct.values[ct.Index(i, j, k)] = float(cubic(ct.PointOf(i, j, k)));
    }
  }
  // Points at fractional voxel positions at least 5 voxels from every face,
  // and one beyond the grid.
  Eigen::Matrix3Xd points(3, 0);
  for (double f : {9.0, 11.37, 13.5, 15.81, 16.99}) {
    points.conservativeResize(3, points.cols() + 1);
    points.col(points.cols() - 1) = ct.PointOf(f + 1.13, f - 0.41, f - 3.7);
  }
  points.conservativeResize(3, points.cols() + 1);
  points.col(points.cols() - 1) = ct.PointOf(-0.6, 4, 4);
  const CtSamples samples = SampleCubic(ct, points);
  const Eigen::Index last = points.cols() - 1;
  double worst_value = 0, worst_gradient = 0;
  for (Eigen::Index i = 0; i < last; ++i) {
    REQUIRE(samples.inside[i]);
    const double value = cubic(points.col(i));
    const Eigen::Vector3d gradient = cubic_gradient_per_m(points.col(i));
    worst_value = std::max(worst_value, std::abs(samples.values_hu[i] - value));
    worst_gradient = std::max(worst_gradient, (samples.gradients_hu_per_m.col(i) - gradient).norm() / gradient.norm());
  }
  INFO("worst value error " << worst_value << " HU, worst relative gradient error " << worst_gradient);
  CHECK(worst_value < 0.004);  // 0.0018 HU: the mirrored border's tail and float voxels
  CHECK(worst_gradient < 1.2e-4);
  CHECK_FALSE(samples.inside[last]);
  CHECK(std::isnan(samples.values_hu[last]));

  io::CtImage thin = ct;
  thin.size.z() = 3;
  thin.values.resize(thin.num_voxels());
  CHECK_THROWS_WITH(SampleCubic(thin, points), Contains("at least 4 voxels"));
}

}  // namespace
}  // namespace dg::stages::preop
