// The embedded-surface overlays against analytic images: a textured triangle
// moved by an affine motion of the mesh covers exactly the pixel centres
// inside its projection with the bilinearly sampled texture there; nearer
// surfaces hide farther ones; through a distorting lens, vertices land on the
// OpenCV model's projection.
#include "stages/overlay/surface_overlay.h"

#include <random>

#include <catch2/catch.hpp>
#include <opencv2/core.hpp>

#include "sim/error.h"
#include "stages/camera_model.h"
#include "tests/stages/overlay/overlay_fixtures.h"

namespace dg::stages::overlay {
namespace {

using testing::OneTet;
using testing::PinholeCalibration;

// An affine motion that keeps planes z = const parallel to the image (so the
// expected texture coordinates are affine in the pixel).
Eigen::Matrix3Xd MoveAffinely(const Eigen::Matrix3Xd& X) {
  Eigen::Matrix3d A;
  A << 1.1, 0.08, 0.0,  //
      -0.05, 0.95, 0.0,  //
      0.0, 0.0, 1.0;
  return (A * X).colwise() + Eigen::Vector3d(0.003, -0.002, 0.01);
}

// 32 x 32 texture whose blue and green grow by 4 levels per texel column and
// row: bilinear sampling of it is linear in the texel coordinate.
cv::Mat GradientTexture() {
  cv::Mat texture(32, 32, CV_8UC3);
  for (int j = 0; j < 32; ++j) {
    for (int i = 0; i < 32; ++i) texture.at<cv::Vec3b>(j, i) = cv::Vec3b(4 * i + 40, 4 * j + 40, 100);
  }
  return texture;
}

// Twice the signed area of (a, b, p).
double Edge(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& p) {
  return (b.x() - a.x()) * (p.y() - a.y()) - (b.y() - a.y()) * (p.x() - a.x());
}

TEST_CASE("overlay: a textured triangle's coverage and colours match the analytic image", "[stages][unit]") {
  const io::CameraCalibration camera = PinholeCalibration(64, 48, 100);
  OverlaySurface surface;
  surface.mesh.vertices_m.resize(3, 3);
  surface.mesh.vertices_m << -0.02, 0.025, -0.005,  //
      -0.015, -0.01, 0.02,                          //
      0.1, 0.1, 0.1;
  surface.mesh.triangles.resize(3, 1);
  surface.mesh.triangles << 0, 1, 2;
  surface.mesh.uvs.resize(2, 3);  // OBJ convention: v up
  surface.mesh.uvs << 0.2, 0.8, 0.45,  //
      0.75, 0.6, 0.25;
  surface.texture = GradientTexture();
  surface.name = "triangle";
  SurfaceOverlay::Options options;
  options.opacity = 1;
  options.lit = false;
  options.supersample = 1;
  SurfaceOverlay overlay(options, OneTet(), {surface}, LensView(camera, Eigen::Isometry3d::Identity()));
  const OverlayLayer layer = overlay.Process(MoveAffinely(OneTet().X_m), 7);
  REQUIRE(layer.frame == 7);
  REQUIRE(layer.bgra.size() == cv::Size(64, 48));

  // The truth: the moved vertices projected, texture coordinates by 2D barycentrics.
  const Eigen::Matrix3Xd moved = MoveAffinely(surface.mesh.vertices_m);
  std::array<Eigen::Vector2d, 3> px;
  for (int k = 0; k < 3; ++k) px[k] = Project(camera, moved.col(k));
  const double area = Edge(px[0], px[1], px[2]);
  int inside = 0, checked = 0;
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 64; ++x) {
      const Eigen::Vector2d p(x, y);
      const Eigen::Vector3d b(Edge(px[1], px[2], p) / area, Edge(px[2], px[0], p) / area, Edge(px[0], px[1], p) / area);
      const cv::Vec4f drawn = layer.bgra.at<cv::Vec4f>(y, x);
      const double margin = 1e-3;  // centres this close to an edge may go either way (vertices are snapped)
      if (b.minCoeff() < -margin) {
        REQUIRE(drawn[3] == 0.0f);
        ++checked;
        continue;
      }
      if (b.minCoeff() < margin) continue;
      ++inside;
      ++checked;
      REQUIRE(drawn[3] == 1.0f);
      const Eigen::Vector2d uv = b[0] * surface.mesh.uvs.col(0) + b[1] * surface.mesh.uvs.col(1) + b[2] * surface.mesh.uvs.col(2);
      const double blue = (4 * (uv.x() * 32 - 0.5) + 40) / 255, green = (4 * ((1 - uv.y()) * 32 - 0.5) + 40) / 255;
      INFO("pixel (" << x << ", " << y << ")");
      REQUIRE(drawn[0] == Approx(blue).margin(1e-3));
      REQUIRE(drawn[1] == Approx(green).margin(1e-3));
      REQUIRE(drawn[2] == Approx(100 / 255.0).margin(1e-4));
    }
  }
  REQUIRE(inside > 200);            // the triangle covers a good part of the image
  REQUIRE(checked > 64 * 48 - 100);  // and few centres lie on its edges
}

// Two unlit squares parallel to the image: where they overlap the nearer one shows, whichever is listed first.
TEST_CASE("overlay: nearer surfaces hide farther ones", "[stages][unit]") {
  const io::CameraCalibration camera = PinholeCalibration(64, 48, 100);
  const auto square = [](double half_m, double z_m, const Eigen::Vector3f& bgr, const std::string& name) {
    OverlaySurface s;
    s.mesh.vertices_m.resize(3, 4);
    s.mesh.vertices_m << -half_m, half_m, half_m, -half_m,  //
        -half_m, -half_m, half_m, half_m,                   //
        z_m, z_m, z_m, z_m;
    s.mesh.triangles.resize(3, 2);
    s.mesh.triangles << 0, 0, 1, 2, 2, 3;
    s.color_bgr = bgr;
    s.name = name;
    return s;
  };
  const OverlaySurface far = square(0.03, 0.12, {0, 0, 1}, "far");
  const OverlaySurface near = square(0.01, 0.08, {1, 0, 0}, "near");
  SurfaceOverlay::Options options;
  options.lit = false;
  options.opacity = 1;
  options.supersample = 1;
  for (const auto& order : {std::vector<OverlaySurface>{far, near}, std::vector<OverlaySurface>{near, far}}) {
    SurfaceOverlay overlay(options, OneTet(), order, LensView(camera, Eigen::Isometry3d::Identity()));
    const OverlayLayer layer = overlay.Process(OneTet().X_m, 0);
    // The near square spans |x|, |y| < 100 * 0.01 / 0.08 = 12.5 px around the centre; the far one 25 px.
    REQUIRE(layer.bgra.at<cv::Vec4f>(24, 32) == cv::Vec4f(1, 0, 0, 1));
    REQUIRE(layer.bgra.at<cv::Vec4f>(24 + 11, 32 - 11) == cv::Vec4f(1, 0, 0, 1));
    REQUIRE(layer.bgra.at<cv::Vec4f>(24 + 14, 32) == cv::Vec4f(0, 0, 1, 1));
    REQUIRE(layer.bgra.at<cv::Vec4f>(2, 2) == cv::Vec4f(0, 0, 0, 0));
  }
}

// Through a distorting lens, each moved vertex's pinhole pixel is the OpenCV model's projection.
TEST_CASE("overlay: vertices land on the distorted projection", "[stages][unit]") {
  io::CameraCalibration camera = PinholeCalibration(640, 480, 500);
  camera.distortion = {-0.28, 0.09, 0.0012, -0.0008, 0.0, 0, 0, 0};
  const Eigen::Isometry3d T_C_S = Eigen::Translation3d(0.001, -0.002, 0.05) * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX());
  const LensView view(camera, T_C_S);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> lateral(-0.035, 0.035), depth(0.03, 0.08);
  int inside = 0;
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d X_S = T_C_S.inverse() * Eigen::Vector3d(lateral(rng), lateral(rng), depth(rng));
    const Eigen::Vector2d expected = Project(camera, T_C_S * X_S);
    if (expected.x() < 0 || expected.y() < 0 || expected.x() > 639 || expected.y() > 479) continue;
    ++inside;
    const Eigen::Vector3d v = view.ToView(X_S);
    const Eigen::Vector2d drawn(camera.fx() * v.x() / v.z() + camera.cx(), camera.fy() * v.y() / v.z() + camera.cy());
    REQUIRE((drawn - expected).norm() < 1e-9);
    REQUIRE(v.z() == Approx((T_C_S * X_S).z()).epsilon(1e-15));
  }
  REQUIRE(inside > 300);
}

// A texture far finer than the image samples it (a one-texel checkerboard of
// 1024 x 1024 on a triangle some 40 pixels across) is drawn from its
// prefiltered level: the mean grey the eye would average it to, without the
// aliasing of sampling the full texture at a sixteenth of its density.
TEST_CASE("overlay: a surface drawn far smaller than its texture samples a prefiltered level", "[stages][unit]") {
  OverlaySurface surface;
  surface.mesh.vertices_m.resize(3, 3);
  surface.mesh.vertices_m << -0.02, 0.025, -0.005, -0.015, -0.01, 0.02, 0.1, 0.1, 0.1;
  surface.mesh.triangles.resize(3, 1);
  surface.mesh.triangles << 0, 1, 2;
  surface.mesh.uvs.resize(2, 3);
  surface.mesh.uvs << 0.0, 1.0, 0.3, 0.1, 0.0, 0.9;
  surface.texture.create(1024, 1024, CV_8UC3);
  for (int y = 0; y < 1024; ++y) {
    for (int x = 0; x < 1024; ++x) surface.texture.at<cv::Vec3b>(y, x) = cv::Vec3b::all((x + y) % 2 ? 255 : 0);
  }
  surface.name = "checkerboard";
  SurfaceOverlay::Options options;
  options.opacity = 1;
  options.lit = false;
  options.supersample = 1;
  SurfaceOverlay overlay(options, OneTet(), {surface},
                         LensView(PinholeCalibration(64, 48, 100), Eigen::Isometry3d::Identity()));
  const OverlayLayer layer = overlay.Process(OneTet().X_m, 0);
  std::vector<float> inside;
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 64; ++x) {
      const cv::Vec4f p = layer.bgra.at<cv::Vec4f>(y, x);
      if (p[3] == 1) inside.push_back(p[0]);
    }
  }
  REQUIRE(inside.size() > 300);
  for (float blue : inside) CHECK(blue == Approx(0.5).margin(0.02));
}

// The ray length per depth, interpolated from a coarse grid of lens
// inversions, against each pixel's own inversion through the same strongly
// distorting lens.
TEST_CASE("overlay: the ray length per depth matches each pixel's inverted ray", "[stages][unit]") {
  io::CameraCalibration camera = PinholeCalibration(643, 481, 500);  // sizes that are not multiples of the grid
  camera.distortion = {-0.28, 0.09, 0.0012, -0.0008, 0.0, 0, 0, 0};
  const cv::Mat length = LensView(camera, Eigen::Isometry3d::Identity()).RayLengthPerDepth();
  REQUIRE(length.size() == cv::Size(643, 481));
  double worst = 0, largest = 0;
  for (int v = 0; v < camera.height; v += 3) {
    for (int u = 0; u < camera.width; u += 3) {
      Eigen::Vector2d normalized;
      REQUIRE(UndistortPixel(camera, Eigen::Vector2d(u, v), &normalized));
      const double exact = std::sqrt(1 + normalized.squaredNorm());
      worst = std::max(worst, std::abs(length.at<float>(v, u) / exact - 1));
      largest = std::max(largest, exact);
    }
  }
  CHECK(largest > 1.2);   // the corners' rays are well off the axis
  CHECK(worst < 5e-5);    // relative
}

// One embedding serves every view: the overlay built from it draws the same
// layer as one that embeds its surfaces itself.
TEST_CASE("overlay: a shared embedding draws as the overlay's own", "[stages][unit]") {
  const sim::TetMesh mesh = OneTet();
  OverlaySurface surface;
  surface.mesh.vertices_m = Eigen::Matrix3Xd(3, 3);
  surface.mesh.vertices_m << -0.01, 0.01, 0.0, -0.01, -0.01, 0.012, 0.1, 0.1, 0.11;
  surface.mesh.triangles = Eigen::Matrix3Xi(3, 1);
  surface.mesh.triangles << 0, 1, 2;
  const LensView view(PinholeCalibration(160, 120, 200), Eigen::Isometry3d::Identity());
  SurfaceOverlay own({}, mesh, {surface}, view);
  SurfaceOverlay shared({}, SurfaceOverlay::Embed(mesh, {surface}), {surface}, view);
  const OverlayLayer a = own.Process(mesh.X_m, 0), b = shared.Process(mesh.X_m, 0);
  REQUIRE(cv::countNonZero(a.bgra.reshape(1) != 0) > 100);
  REQUIRE(cv::norm(a.bgra, b.bgra, cv::NORM_INF) == 0);
  OverlaySurface other = surface;
  other.mesh.vertices_m.conservativeResize(3, 4);
  other.mesh.vertices_m.col(3) = Eigen::Vector3d(0, 0, 0.12);
  REQUIRE_THROWS_WITH(SurfaceOverlay({}, SurfaceOverlay::Embed(mesh, {surface}), {other}, view),
                      Catch::Contains("the embedding is not of the surfaces' 4 vertices"));
}

TEST_CASE("overlay: bad surfaces, options and node counts are rejected", "[stages][unit]") {
  const io::CameraCalibration camera = PinholeCalibration(64, 48, 100);
  const LensView view(camera, Eigen::Isometry3d::Identity());
  OverlaySurface surface;
  surface.mesh.vertices_m = Eigen::Matrix3Xd::Constant(3, 3, 0.1);
  surface.mesh.triangles = Eigen::Matrix3Xi(3, 1);
  surface.mesh.triangles << 0, 1, 2;
  surface.texture = GradientTexture();
  surface.name = "untextured.obj";
  REQUIRE_THROWS_WITH(SurfaceOverlay({}, OneTet(), {surface}, view), Catch::Contains("without per-vertex texture"));
  surface.texture = cv::Mat();
  REQUIRE_THROWS_WITH(SurfaceOverlay({}, OneTet(), {}, view), Catch::Contains("no surfaces"));
  SurfaceOverlay::Options bad;
  bad.opacity = 2;
  REQUIRE_THROWS_WITH(SurfaceOverlay(bad, OneTet(), {surface}, view), Catch::Contains("opacity"));
  SurfaceOverlay overlay({}, OneTet(), {surface}, view);
  REQUIRE_THROWS_WITH(overlay.Process(Eigen::Matrix3Xd::Zero(3, 5), 3), Catch::Contains("the mesh has 4"));
}

}  // namespace
}  // namespace dg::stages::overlay
