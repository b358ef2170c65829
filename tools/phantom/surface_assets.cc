#include "tools/phantom/surface_assets.h"

#include <cmath>
#include <numbers>
#include <random>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

namespace dg::tools::phantom {
namespace {

// Grid resolution of the skin and its texture: fine enough that the facets are
// far below a pixel at the working distance, and the texture has detail to track.
constexpr int kGridU = 256, kGridV = 128;
constexpr int kTextureWidth = 2048, kTextureHeight = 1024;

const cv::Scalar kTissueBgr(72, 82, 178), kVesselBgr(48, 42, 118), kMarkerBgr(40, 205, 45);

int GridVertex(int i, int j) { return j * (kGridU + 1) + i; }

// Tissue colour with smooth variation and fine speckle: corners and blobs for
// the tracker at every scale from a few pixels to a few dozen.
cv::Mat TissueTexture(std::mt19937_64& rng) {
  cv::Mat texture(kTextureHeight, kTextureWidth, CV_8UC3, kTissueBgr);
  cv::Mat variation(kTextureHeight / 16, kTextureWidth / 16, CV_32F);
  std::normal_distribution<float> normal(0.f, 1.f);
  for (int r = 0; r < variation.rows; ++r) {
    for (int c = 0; c < variation.cols; ++c) variation.at<float>(r, c) = normal(rng);
  }
  cv::resize(variation, variation, texture.size(), 0, 0, cv::INTER_CUBIC);
  cv::GaussianBlur(variation, variation, cv::Size(), 12);
  cv::normalize(variation, variation, -1, 1, cv::NORM_MINMAX);
  std::uniform_real_distribution<double> uniform(0, 1);
  for (int r = 0; r < texture.rows; ++r) {
    for (int c = 0; c < texture.cols; ++c) {
      cv::Vec3b& px = texture.at<cv::Vec3b>(r, c);
      const float shade = 1 + 0.18f * variation.at<float>(r, c);
      for (int k = 0; k < 3; ++k) px[k] = cv::saturate_cast<uchar>(px[k] * shade);
    }
  }
  for (int spot = 0; spot < 9000; ++spot) {
    const cv::Point centre(static_cast<int>(uniform(rng) * kTextureWidth), static_cast<int>(uniform(rng) * kTextureHeight));
    const double lightness = uniform(rng) < 0.5 ? 0.75 : 1.2;
    const cv::Scalar colour = kTissueBgr * lightness;
    cv::circle(texture, centre, 1 + static_cast<int>(uniform(rng) * 4), colour, cv::FILLED, cv::LINE_AA);
  }
  return texture;
}

// Branching vessels: random walks that fork and thin out.
void DrawVessels(cv::Mat* texture, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> uniform(0, 1);
  struct Branch {
    cv::Point2d at;
    double heading, width;
    int steps;
  };
  std::vector<Branch> branches;
  for (int trunk = 0; trunk < 14; ++trunk) {
    branches.push_back({{uniform(rng) * kTextureWidth, kTextureHeight * (0.05 + 0.9 * uniform(rng))},
                        uniform(rng) * 2 * std::numbers::pi, 7.0 + 3 * uniform(rng), 60});
  }
  while (!branches.empty()) {
    Branch b = branches.back();
    branches.pop_back();
    for (int s = 0; s < b.steps && b.width >= 1.0; ++s) {
      b.heading += 0.35 * (uniform(rng) - 0.5);
      const cv::Point2d next = b.at + 14.0 * cv::Point2d(std::cos(b.heading), std::sin(b.heading));
      cv::line(*texture, b.at * 16, next * 16, kVesselBgr, static_cast<int>(b.width), cv::LINE_AA, 4);
      b.at = next;
      b.width *= 0.985;
      if (uniform(rng) < 0.05) branches.push_back({b.at, b.heading + (uniform(rng) < 0.5 ? 0.7 : -0.7), 0.7 * b.width, b.steps - s});
    }
  }
}

// A disc of radius r on the surface around (u, v), as the ellipse it is in
// texture space: the surface metric G = J^T J maps texture offsets to lengths,
// so the disc is { d : d^T G d <= r^2 }.
void DrawMarker(cv::Mat* texture, const HeartGeometry& geometry, double u, double v, double radius_m) {
  constexpr double h = 1e-5;
  Eigen::Matrix<double, 3, 2> J;
  J.col(0) = (geometry.SurfacePoint(u + h, v) - geometry.SurfacePoint(u - h, v)) / (2 * h);
  J.col(1) = (geometry.SurfacePoint(u, v + h) - geometry.SurfacePoint(u, v - h)) / (2 * h);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> metric(J.transpose() * J);
  const Eigen::Matrix2d inverse_sqrt = metric.operatorInverseSqrt();
  std::vector<cv::Point> outline;
  constexpr int kShift = 8;  // sub-pixel vertices for fillPoly
  for (int k = 0; k < 72; ++k) {
    const double t = 2 * std::numbers::pi * k / 72;
    const Eigen::Vector2d d = radius_m * inverse_sqrt * Eigen::Vector2d(std::cos(t), std::sin(t));
    // Texel centres sit at (col + 0.5) / width in texture coordinates.
    const double col = (u + d.x()) * kTextureWidth - 0.5, row = (v + d.y()) * kTextureHeight - 0.5;
    outline.emplace_back(static_cast<int>(std::lround(col * (1 << kShift))), static_cast<int>(std::lround(row * (1 << kShift))));
  }
  cv::fillPoly(*texture, std::vector<std::vector<cv::Point>>{outline}, kMarkerBgr, cv::LINE_AA, kShift);
}

io::SurfaceMesh EllipsoidMesh(const Ellipsoid& ellipsoid, int n_azimuth, int n_polar) {
  io::SurfaceMesh mesh;
  mesh.vertices_m.resize(3, 2 + n_azimuth * (n_polar - 1));
  mesh.vertices_m.col(0) = ellipsoid.centre_m + Eigen::Vector3d(0, 0, ellipsoid.semi_axes_m.z());
  mesh.vertices_m.col(1) = ellipsoid.centre_m - Eigen::Vector3d(0, 0, ellipsoid.semi_axes_m.z());
  auto ring = [&](int j, int i) { return 2 + (j - 1) * n_azimuth + (i % n_azimuth); };
  for (int j = 1; j < n_polar; ++j) {
    const double polar = std::numbers::pi * j / n_polar;
    for (int i = 0; i < n_azimuth; ++i) {
      const double azimuth = 2 * std::numbers::pi * i / n_azimuth;
      mesh.vertices_m.col(ring(j, i)) =
          ellipsoid.centre_m + ellipsoid.semi_axes_m.cwiseProduct(Eigen::Vector3d(
                                   std::sin(polar) * std::cos(azimuth), std::sin(polar) * std::sin(azimuth), std::cos(polar)));
    }
  }
  std::vector<Eigen::Vector3i> triangles;
  for (int i = 0; i < n_azimuth; ++i) {
    triangles.emplace_back(0, ring(1, i), ring(1, i + 1));
    triangles.emplace_back(1, ring(n_polar - 1, i + 1), ring(n_polar - 1, i));
    for (int j = 1; j + 1 < n_polar; ++j) {
      triangles.emplace_back(ring(j, i), ring(j + 1, i), ring(j + 1, i + 1));
      triangles.emplace_back(ring(j, i), ring(j + 1, i + 1), ring(j, i + 1));
    }
  }
  mesh.triangles.resize(3, static_cast<Eigen::Index>(triangles.size()));
  for (size_t t = 0; t < triangles.size(); ++t) mesh.triangles.col(static_cast<Eigen::Index>(t)) = triangles[t];
  return mesh;
}

}  // namespace

SurfaceAssets MakeSurfaceAssets(const PhantomSpec& spec, const HeartGeometry& geometry, double camera_azimuth_u) {
  SurfaceAssets assets;
  std::mt19937_64 rng(spec.seed * 0xD1B54A32D192ED03ULL + 2);

  // The skin: a (kGridU + 1) x (kGridV + 1) grid; the seam column u = 1 and
  // the pole row v = 0 repeat vertices so each has its own texture coordinate.
  const int n = (kGridU + 1) * (kGridV + 1);
  assets.skin.vertices_m.resize(3, n);
  assets.skin.uvs.resize(2, n);
  assets.grid_uv.resize(2, n);
  for (int j = 0; j <= kGridV; ++j) {
    for (int i = 0; i <= kGridU; ++i) {
      const double u = double(i) / kGridU, v = double(j) / kGridV;
      const int k = GridVertex(i, j);
      assets.skin.vertices_m.col(k) = geometry.SurfacePoint(u, v);
      assets.grid_uv.col(k) << u, v;
      assets.skin.uvs.col(k) << u, 1 - v;
    }
  }
  assets.skin.triangles.resize(3, 2 * kGridU * kGridV);
  int t = 0;
  for (int j = 0; j < kGridV; ++j) {
    for (int i = 0; i < kGridU; ++i) {
      // Counter-clockwise seen from outside: u runs counter-clockwise seen from above, v downwards.
      assets.skin.triangles.col(t++) << GridVertex(i, j), GridVertex(i, j + 1), GridVertex(i + 1, j + 1);
      assets.skin.triangles.col(t++) << GridVertex(i, j), GridVertex(i + 1, j + 1), GridVertex(i + 1, j);
    }
  }

  assets.texture = TissueTexture(rng);
  DrawVessels(&assets.texture, rng);

  // Fiducials on grid vertices spread over the side the camera sees: a jittered
  // ring of azimuths, alternating high and low on the surface.
  std::uniform_real_distribution<double> jitter(-1.0, 1.0);
  const int count = spec.fiducials;
  for (int f = 0; f < count; ++f) {
    const double u = camera_azimuth_u + 0.24 * ((f + 0.5) / count - 0.5) + 0.01 * jitter(rng);
    const double v = (f % 2 ? 0.62 : 0.38) + 0.06 * jitter(rng);
    const int i = static_cast<int>(std::lround((u - std::floor(u)) * kGridU)) % kGridU;
    const int j = static_cast<int>(std::lround(v * kGridV));
    assets.fiducial_vertices.push_back(GridVertex(i, j));
    DrawMarker(&assets.texture, geometry, double(i) / kGridU, double(j) / kGridV, SurfaceAssets::kMarkerRadius_m);
  }
  assets.fiducials_S.resize(3, count);
  for (int f = 0; f < count; ++f) assets.fiducials_S.col(f) = assets.skin.vertices_m.col(assets.fiducial_vertices[f]);

  // Dense surface points: every fourth grid vertex, seam and pole repeats left out.
  for (int j = 4; j < kGridV; j += 4) {
    for (int i = 0; i < kGridU; i += 4) assets.surface_point_vertices.push_back(GridVertex(i, j));
  }
  assets.surface_points_S.resize(3, static_cast<Eigen::Index>(assets.surface_point_vertices.size()));
  for (size_t k = 0; k < assets.surface_point_vertices.size(); ++k) {
    assets.surface_points_S.col(static_cast<Eigen::Index>(k)) = assets.skin.vertices_m.col(assets.surface_point_vertices[k]);
  }

  // Internal features: each chamber's centre and its six axis poles.
  for (const Ellipsoid& chamber : geometry.chambers()) assets.chamber_meshes.push_back(EllipsoidMesh(chamber, 64, 32));
  assets.internal_points_S.resize(3, 7 * static_cast<Eigen::Index>(geometry.chambers().size()));
  int p = 0;
  for (const Ellipsoid& chamber : geometry.chambers()) {
    assets.internal_points_S.col(p++) = chamber.centre_m;
    for (int axis = 0; axis < 3; ++axis) {
      for (double sign : {-1.0, 1.0}) {
        Eigen::Vector3d offset = Eigen::Vector3d::Zero();
        offset[axis] = sign * chamber.semi_axes_m[axis];
        assets.internal_points_S.col(p++) = chamber.centre_m + offset;
      }
    }
  }
  return assets;
}

MountAssets MakeMountAssets(uint64_t seed) {
  MountAssets mount;
  const double half = HeartGeometry::kMountHalfWidth_m;
  mount.plate.vertices_m.resize(3, 4);
  mount.plate.vertices_m << -half, half, half, -half,  //
      -half, -half, half, half,                        //
      0, 0, 0, 0;
  mount.plate.uvs.resize(2, 4);
  mount.plate.uvs << 0, 1, 1, 0,  //
      0, 0, 1, 1;
  mount.plate.triangles.resize(3, 2);
  mount.plate.triangles << 0, 0,  //
      1, 2,                       //
      2, 3;
  // A matte blue-grey plastic with faint mottling.
  mount.texture = cv::Mat(512, 512, CV_8UC3, cv::Scalar(120, 105, 95));
  std::mt19937_64 rng(seed * 0x8CB92BA72F3D8DD7ULL + 3);
  std::uniform_real_distribution<double> uniform(0, 1);
  for (int spot = 0; spot < 3000; ++spot) {
    const cv::Point centre(static_cast<int>(uniform(rng) * 512), static_cast<int>(uniform(rng) * 512));
    cv::circle(mount.texture, centre, 1 + static_cast<int>(uniform(rng) * 3), cv::Scalar(120, 105, 95) * (0.8 + 0.4 * uniform(rng)),
               cv::FILLED, cv::LINE_AA);
  }
  return mount;
}

}  // namespace dg::tools::phantom
