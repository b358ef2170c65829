// The volume overlay against analytic truths: a block of constant density is
// as opaque as 1 - exp(-sigma L) for each pixel's true path length L through
// it, and a dense ball in the CT follows the mesh's deformation to where the
// moved ball projects.
#include "stages/overlay/volume_overlay.h"

#include <cmath>
#include <memory>

#include <catch2/catch.hpp>

#include "sim/error.h"
#include "stages/camera_model.h"
#include "tests/sim/box_mesh.h"
#include "tests/stages/overlay/overlay_fixtures.h"

namespace dg::stages::overlay {
namespace {

constexpr double kHalf_m = 0.01;  // the block is [-1 cm, 1 cm]^3 in the scan frame

sim::TetMesh CentredBlock() {
  sim::TetMesh mesh = sim::testing::MakeBoxMesh(4, 4, 4, Eigen::Vector3d::Constant(2 * kHalf_m), 0.2, 3);
  mesh.X_m.array() -= kHalf_m;
  return mesh;
}

io::VolumeI16 UniformCt(double spacing_m, std::int16_t hu) {
  io::VolumeI16 ct;
  const int n = static_cast<int>(std::ceil(2.4 * kHalf_m / spacing_m)) + 1;
  ct.size = Eigen::Vector3i::Constant(n);
  ct.spacing_m = Eigen::Vector3d::Constant(spacing_m);
  ct.origin_m = Eigen::Vector3d::Constant(-1.2 * kHalf_m);
  ct.values.assign(ct.num_voxels(), hu);
  return ct;
}

std::shared_ptr<const io::VolumeI16> Shared(io::VolumeI16 ct) {
  return std::make_shared<const io::VolumeI16>(std::move(ct));
}

const Eigen::Isometry3d kT_C_S = Eigen::Translation3d(0.002, -0.001, 0.07) *
                                 Eigen::AngleAxisd(0.5, Eigen::Vector3d(1, 1, 0).normalized());

// Where the ray through pixel (x, y) enters and leaves the block: depth z in C at both ends.
bool RayThroughBlock(const io::CameraCalibration& camera, int x, int y, double* length_m, double* z_extent_m) {
  const Eigen::Vector3d d_C((x - camera.cx()) / camera.fx(), (y - camera.cy()) / camera.fy(), 1);
  const Eigen::Vector3d o_S = kT_C_S.inverse().translation();
  const Eigen::Vector3d d_S = kT_C_S.linear().transpose() * d_C;
  double t_in = 0, t_out = 1e9;
  for (int i = 0; i < 3; ++i) {
    const double a = (-kHalf_m - o_S[i]) / d_S[i], b = (kHalf_m - o_S[i]) / d_S[i];
    t_in = std::max(t_in, std::min(a, b));
    t_out = std::min(t_out, std::max(a, b));
  }
  if (t_out <= t_in) return false;
  *length_m = (t_out - t_in) * d_C.norm();
  *z_extent_m = t_out - t_in;  // d_C.z() = 1
  return true;
}

// Slices sample the block's depth every spacing, so a ray crossing n slices
// has its path length right to 1/n: checked where n >= 50 (2% of the exponent,
// under 2% of the opacity), away from the silhouette.
TEST_CASE("volume overlay: a constant-density block is 1 - exp(-sigma L) opaque", "[stages][unit]") {
  const io::CameraCalibration camera = testing::PinholeCalibration(160, 120, 200);
  constexpr float kSigma = 60;  // per metre: sigma L from 0 to about 2
  TransferFunction transfer;
  transfer.points = {{0, {1, 1, 1}, kSigma}};
  VolumeOverlay::Options options;
  options.slice_spacing_m = 0.2e-3;
  const sim::TetMesh mesh = CentredBlock();
  VolumeOverlay overlay(options, mesh, Shared(UniformCt(2e-3, 100)), transfer, LensView(camera, kT_C_S));
  const OverlayLayer layer = overlay.Process(mesh.X_m, 3);
  REQUIRE(layer.frame == 3);
  REQUIRE(overlay.last_slices() > 100);

  int checked = 0;
  double worst = 0;
  for (int y = 1; y < 119; ++y) {
    for (int x = 1; x < 159; ++x) {
      const cv::Vec4f drawn = layer.bgra.at<cv::Vec4f>(y, x);
      double length, z_extent;
      if (!RayThroughBlock(camera, x, y, &length, &z_extent)) {
        // Outside the silhouette by a pixel: nothing drawn.
        bool near_silhouette = false;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) near_silhouette |= RayThroughBlock(camera, x + dx, y + dy, &length, &z_extent);
        if (!near_silhouette) REQUIRE(drawn[3] == 0.0f);
        continue;
      }
      REQUIRE(drawn[0] == Approx(drawn[3]).margin(1e-6));  // white emission: colour = opacity
      if (z_extent < 50 * options.slice_spacing_m) continue;
      const double expected = 1 - std::exp(-kSigma * length);
      worst = std::max(worst, std::abs(drawn[3] - expected) / expected);
      ++checked;
    }
  }
  INFO("worst relative opacity error " << worst << " over " << checked << " pixels");
  REQUIRE(checked > 2000);
  REQUIRE(worst < 0.02);
}

// The CT is sampled at reference positions: a dense ball at q, with the nodes
// moved by an affine map M, is drawn where M q projects (centroid of opacity).
TEST_CASE("volume overlay: CT features follow the mesh's deformation", "[stages][unit]") {
  const io::CameraCalibration camera = testing::PinholeCalibration(160, 120, 200);
  io::VolumeI16 ct = UniformCt(0.4e-3, 0);
  const Eigen::Vector3d q(0.003, -0.002, 0.001);
  for (int k = 0; k < ct.size.z(); ++k)
    for (int j = 0; j < ct.size.y(); ++j)
      for (int i = 0; i < ct.size.x(); ++i) {
        const Eigen::Vector3d X = ct.origin_m + ct.spacing_m.cwiseProduct(Eigen::Vector3d(i, j, k));
        if ((X - q).norm() < 2.5e-3) ct.at(i, j, k) = 1000;
      }
  TransferFunction transfer;
  transfer.points = {{400, {1, 1, 1}, 0}, {600, {1, 1, 1}, 3000}};
  const sim::TetMesh mesh = CentredBlock();
  Eigen::Matrix3d M;
  M << 1.15, 0.1, 0.0,  //
      -0.05, 0.9, 0.08,  //
      0.02, 0.0, 1.05;
  const Eigen::Vector3d shift(0.002, 0.001, -0.003);
  VolumeOverlay overlay({}, mesh, Shared(ct), transfer, LensView(camera, kT_C_S));
  const OverlayLayer layer = overlay.Process((M * mesh.X_m).colwise() + shift, 0);
  double sum = 0;
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) {
      const double a = layer.bgra.at<cv::Vec4f>(y, x)[3];
      sum += a;
      centroid += a * Eigen::Vector2d(x, y);
    }
  REQUIRE(sum > 50);  // the ball is drawn: tens of pixels
  const Eigen::Vector2d expected = Project(camera, kT_C_S * (M * q + shift));
  INFO("centroid " << (centroid / sum).transpose() << ", expected " << expected.transpose());
  REQUIRE((centroid / sum - expected).norm() < 0.3);
}

TEST_CASE("volume overlay: bad options, transfer functions and CTs are rejected", "[stages][unit]") {
  const io::CameraCalibration camera = testing::PinholeCalibration(16, 12, 20);
  const LensView view(camera, kT_C_S);
  const sim::TetMesh mesh = CentredBlock();
  TransferFunction transfer;
  transfer.points = {{100, {1, 1, 1}, 5}, {50, {1, 1, 1}, 5}};
  REQUIRE_THROWS_WITH(VolumeOverlay({}, mesh, Shared(UniformCt(2e-3, 0)), transfer, view),
                      Catch::Contains("does not increase in HU"));
  VolumeOverlay::Options bad;
  bad.slice_spacing_m = 0;
  REQUIRE_THROWS_WITH(VolumeOverlay(bad, mesh, Shared(UniformCt(2e-3, 0)), TransferFunction::CardiacDefault(), view),
                      Catch::Contains("slice_spacing_m"));
  io::VolumeI16 flat = UniformCt(2e-3, 0);
  flat.size.z() = 1;
  flat.values.resize(flat.num_voxels());
  REQUIRE_THROWS_WITH(VolumeOverlay({}, mesh, Shared(flat), TransferFunction::CardiacDefault(), view),
                      Catch::Contains("fewer than 2 voxels"));
  REQUIRE_THROWS_WITH(VolumeOverlay({}, mesh, nullptr, TransferFunction::CardiacDefault(), view),
                      Catch::Contains("missing"));
}

}  // namespace
}  // namespace dg::stages::overlay
