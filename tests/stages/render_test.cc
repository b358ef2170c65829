#include "stages/render/rasterizer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include <Eigen/Dense>
#include <catch2/catch.hpp>
#include <opencv2/core.hpp>
#include <tbb/global_control.h>

#include "sim/error.h"
#include "stages/render/texture_sampler.h"

namespace dg::stages::render {
namespace {

using Catch::Matchers::Contains;
using Catch::Matchers::WithinAbs;

PinholeCamera TestCamera(double f = 200, int width = 160, int height = 120) {
  PinholeCamera camera;
  camera.fx = camera.fy = f;
  camera.cx = (width - 1) / 2.0;
  camera.cy = (height - 1) / 2.0;
  camera.width = width;
  camera.height = height;
  return camera;
}

Eigen::Vector3d Ray(const PinholeCamera& camera, double u, double v) {
  return {(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0};
}

// Vertices at depth z on the rays through the given pixels, so their images are known exactly.
TriangleMesh MeshThroughPixels(const PinholeCamera& camera, const std::vector<Eigen::Vector2d>& pixels, double z,
                               const std::vector<Eigen::Vector3i>& triangles) {
  TriangleMesh mesh;
  mesh.positions_C.resize(3, pixels.size());
  for (std::size_t i = 0; i < pixels.size(); ++i)
    mesh.positions_C.col(i) = (z * Ray(camera, pixels[i].x(), pixels[i].y())).cast<float>();
  mesh.triangles.resize(3, triangles.size());
  for (std::size_t t = 0; t < triangles.size(); ++t) mesh.triangles.col(t) = triangles[t];
  return mesh;
}

// A material whose colour is its albedo times color, unlit: ambient 1, no diffuse.
Material Unlit(const Eigen::Vector3f& color = Eigen::Vector3f::Ones()) {
  Material material;
  material.color = color;
  material.ambient = 1;
  material.diffuse = 0;
  return material;
}

// Signed distance (pixels) of p from the line a -> b, positive to the right in
// an image with y down (inside, for a clockwise-on-screen polygon).
double SideOf(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& p) {
  const Eigen::Vector2d d = b - a;
  return (d.x() * (p.y() - a.y()) - d.y() * (p.x() - a.x())) / d.norm();
}

// Distance inside a convex polygon (negative outside), either winding.
double InsideDistance(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& p) {
  double area = 0;
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    const Eigen::Vector2d& a = polygon[i];
    const Eigen::Vector2d& b = polygon[(i + 1) % polygon.size()];
    area += a.x() * b.y() - a.y() * b.x();
  }
  double distance = INFINITY;
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    const double side = SideOf(polygon[i], polygon[(i + 1) % polygon.size()], p);
    distance = std::min(distance, area > 0 ? side : -side);
  }
  return distance;
}

bool BitIdentical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && a.isContinuous() && b.isContinuous() &&
         std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

// Many overlapping triangles across tiles, textured, smooth-normalled, shiny.
struct RandomScene {
  TriangleMesh mesh;
  cv::Mat texture;
  Material material;
};

RandomScene MakeRandomScene(const PinholeCamera& camera, int num_triangles, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-20, camera.width + 20), v(-20, camera.height + 20), z(0.3, 2.0);
  std::uniform_real_distribution<float> unit(0, 1), offset(-40, 40);
  RandomScene scene;
  const int n = 3 * num_triangles;
  scene.mesh.positions_C.resize(3, n);
  scene.mesh.normals_C.resize(3, n);
  scene.mesh.uvs.resize(2, n);
  scene.mesh.triangles.resize(3, num_triangles);
  for (int t = 0; t < num_triangles; ++t) {
    const double u0 = u(rng), v0 = v(rng);
    for (int k = 0; k < 3; ++k) {
      const int i = 3 * t + k;
      scene.mesh.positions_C.col(i) = (z(rng) * Ray(camera, u0 + offset(rng), v0 + offset(rng))).cast<float>();
      scene.mesh.normals_C.col(i) = Eigen::Vector3f(unit(rng) - 0.5f, unit(rng) - 0.5f, -1);
      scene.mesh.uvs.col(i) = Eigen::Vector2f(unit(rng), unit(rng));
      scene.mesh.triangles(k, t) = i;
    }
  }
  scene.texture.create(64, 64, CV_8UC3);
  cv::randu(scene.texture, 0, 256);
  scene.material.texture = &scene.texture;
  scene.material.specular = 0.4f;
  scene.material.shininess = 20;
  return scene;
}

}  // namespace

// A flat triangle covers exactly the pixel centres inside it (edge functions
// evaluated independently here), at its depth and colour; the count matches its area.
TEST_CASE("render: single triangle coverage matches the pixel centres inside it", "[stages][unit]") {
  const PinholeCamera camera = TestCamera();
  const std::vector<Eigen::Vector2d> corners = {{12.3, 10.7}, {140.6, 30.2}, {50.1, 105.9}};
  Rasterizer rasterizer(camera);
  rasterizer.Clear(Eigen::Vector3f::Zero());
  rasterizer.Draw(MeshThroughPixels(camera, corners, 1.0, {{0, 1, 2}}), Unlit({0.2f, 0.4f, 0.6f}), Light{}, 7);
  const cv::Mat ids = rasterizer.ObjectIds(), depth = rasterizer.Depth(), color = rasterizer.Color();

  int covered = 0;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const bool drawn = ids.at<int>(y, x) == 7;
      covered += drawn;
      const double inside = InsideDistance(corners, Eigen::Vector2d(x, y));
      if (std::abs(inside) < 0.01) continue;  // within vertex snapping (1/512 px) of an edge: either is right
      INFO("pixel " << x << ", " << y << " inside by " << inside);
      REQUIRE(drawn == (inside > 0));
      if (!drawn) continue;
      REQUIRE_THAT(depth.at<float>(y, x), WithinAbs(1.0, 1e-6));
      const cv::Vec3f bgr = color.at<cv::Vec3f>(y, x);
      REQUIRE_THAT(bgr[0], WithinAbs(0.2, 1e-6));
      REQUIRE_THAT(bgr[1], WithinAbs(0.4, 1e-6));
      REQUIRE_THAT(bgr[2], WithinAbs(0.6, 1e-6));
    }
  }
  const Eigen::Vector2d e1 = corners[1] - corners[0], e2 = corners[2] - corners[0];
  const double area = 0.5 * std::abs(e1.x() * e2.y() - e1.y() * e2.x());
  REQUIRE_THAT(covered, WithinAbs(area, 0.01 * area));
}

// Triangles sharing edges (a fan whose edges run through pixel centres, mixed
// windings) cover every pixel of their union exactly once: no cracks, no overlaps.
TEST_CASE("render: triangles sharing edges cover each pixel exactly once", "[stages][unit]") {
  const PinholeCamera camera = TestCamera();
  // Ring vertices on whole pixels: the spokes and rim pass through many pixel centres.
  std::vector<Eigen::Vector2d> pixels = {{80, 60}};
  const int spokes = 16;
  for (int i = 0; i < spokes; ++i) {
    const double angle = 2 * M_PI * i / spokes;
    pixels.emplace_back(std::round(80 + 70 * std::cos(angle)), std::round(60 + 55 * std::sin(angle)));
  }
  const std::vector<Eigen::Vector2d> rim(pixels.begin() + 1, pixels.end());

  cv::Mat count = cv::Mat::zeros(camera.height, camera.width, CV_32SC1);
  Rasterizer rasterizer(camera);
  for (int i = 0; i < spokes; ++i) {
    const int a = 1 + i, b = 1 + (i + 1) % spokes;
    const Eigen::Vector3i triangle = i % 3 == 0 ? Eigen::Vector3i(0, b, a) : Eigen::Vector3i(0, a, b);
    rasterizer.Clear(Eigen::Vector3f::Zero());
    rasterizer.Draw(MeshThroughPixels(camera, pixels, 0.5, {triangle}), Unlit(), Light{}, i);
    const cv::Mat ids = rasterizer.ObjectIds();
    for (int y = 0; y < camera.height; ++y)
      for (int x = 0; x < camera.width; ++x) count.at<int>(y, x) += ids.at<int>(y, x) == i;
  }

  int interior = 0;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      INFO("pixel " << x << ", " << y);
      const int n = count.at<int>(y, x);
      REQUIRE(n <= 1);
      const double inside = InsideDistance(rim, Eigen::Vector2d(x, y));
      if (inside > 0.01) {
        REQUIRE(n == 1);
        ++interior;
      } else if (inside < -0.01) {
        REQUIRE(n == 0);
      }
    }
  }
  REQUIRE(interior > 10000);
}

// The nearer of two overlapping surfaces is what remains, whichever is drawn first.
TEST_CASE("render: nearer surfaces hide farther ones in any draw order", "[stages][unit]") {
  const PinholeCamera camera = TestCamera();
  const auto square = [&](double u0, double v0, double u1, double v1, double z) {
    return MeshThroughPixels(camera, {{u0, v0}, {u1, v0}, {u1, v1}, {u0, v1}}, z, {{0, 1, 2}, {0, 2, 3}});
  };
  const TriangleMesh near_square = square(19.5, 19.5, 100.5, 80.5, 0.5);
  const TriangleMesh far_square = square(59.5, 39.5, 140.5, 100.5, 1.0);

  Rasterizer near_first(camera), far_first(camera);
  near_first.Clear(Eigen::Vector3f::Zero());
  near_first.Draw(near_square, Unlit(), Light{}, 1);
  near_first.Draw(far_square, Unlit(), Light{}, 2);
  far_first.Clear(Eigen::Vector3f::Zero());
  far_first.Draw(far_square, Unlit(), Light{}, 2);
  far_first.Draw(near_square, Unlit(), Light{}, 1);

  for (Rasterizer* rasterizer : {&near_first, &far_first}) {
    const cv::Mat ids = rasterizer->ObjectIds(), depth = rasterizer->Depth();
    for (int y = 20; y <= 100; ++y) {
      for (int x = 20; x <= 140; ++x) {
        const bool in_near = x <= 100 && y <= 80, in_far = x >= 60 && y >= 40;
        if (!in_near && !in_far) continue;
        INFO("pixel " << x << ", " << y);
        REQUIRE(ids.at<int>(y, x) == (in_near ? 1 : 2));
        REQUIRE_THAT(depth.at<float>(y, x), WithinAbs(in_near ? 0.5 : 1.0, 1e-6));
      }
    }
  }
  REQUIRE(BitIdentical(near_first.Depth(), far_first.Depth()));
  REQUIRE(BitIdentical(near_first.ObjectIds(), far_first.ObjectIds()));
}

// On a plane receding steeply in depth, the texture coordinate read back at
// every pixel equals the ray-plane intersection's within one texel, where
// screen-linear interpolation would be off by many.
TEST_CASE("render: texturing is perspective-correct", "[stages][unit]") {
  const PinholeCamera camera = TestCamera(150);
  // P(s, t) = origin + s edge_s + t edge_t with (u, v) = (s, t); z from 0.4 m to 1.4 m across s.
  const Eigen::Vector3d origin(-0.15, -0.12, 0.4), edge_s(0.5, 0, 1.0), edge_t(0, 0.24, 0);
  TriangleMesh mesh;
  mesh.positions_C.resize(3, 4);
  mesh.uvs.resize(2, 4);
  const Eigen::Vector2f corner_uvs[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (int i = 0; i < 4; ++i) {
    mesh.uvs.col(i) = corner_uvs[i];
    mesh.positions_C.col(i) = (origin + corner_uvs[i].x() * edge_s + corner_uvs[i].y() * edge_t).cast<float>();
  }
  mesh.triangles.resize(3, 2);
  mesh.triangles << 0, 0, 1, 2, 2, 3;
  // A 256 x 256 gradient: blue = column, green = row, so bilinear sampling returns
  // blue = 256 u - 1/2 and green = 256 v - 1/2 away from the borders.
  cv::Mat texture(256, 256, CV_8UC3);
  for (int j = 0; j < 256; ++j)
    for (int i = 0; i < 256; ++i) texture.at<cv::Vec3b>(j, i) = cv::Vec3b(i, j, 0);
  Material material = Unlit();
  material.texture = &texture;

  Rasterizer rasterizer(camera);
  rasterizer.Clear(Eigen::Vector3f::Zero());
  rasterizer.Draw(mesh, material, Light{}, 0);
  const cv::Mat color = rasterizer.Color();

  const auto project = [&](const Eigen::Vector3d& p) {
    return Eigen::Vector2d(camera.fx * p.x() / p.z() + camera.cx, camera.fy * p.y() / p.z() + camera.cy);
  };
  const Eigen::Vector2d screen[4] = {project(origin), project(origin + edge_s), project(origin + edge_s + edge_t),
                                     project(origin + edge_t)};
  double max_error = 0, max_affine_error = 0;
  int checked = 0;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      Eigen::Matrix3d system;
      system << edge_s, edge_t, -Ray(camera, x, y);
      const Eigen::Vector3d st_lambda = system.colPivHouseholderQr().solve(-origin);
      const Eigen::Vector2d truth = st_lambda.head<2>();
      if (truth.minCoeff() < 0.05 || truth.maxCoeff() > 0.95) continue;
      const cv::Vec3f bgr = color.at<cv::Vec3f>(y, x);
      const Eigen::Vector2d read((255 * bgr[0] + 0.5) / 256, (255 * bgr[1] + 0.5) / 256);
      max_error = std::max(max_error, (read - truth).cwiseAbs().maxCoeff());
      // What screen-linear interpolation over the triangle holding the pixel would give.
      const Eigen::Vector2d p(x, y);
      const int c = SideOf(screen[0], screen[2], p) * SideOf(screen[0], screen[2], screen[1]) > 0 ? 1 : 3;
      Eigen::Matrix2d basis;
      basis << screen[c] - screen[0], screen[2] - screen[0];
      const Eigen::Vector2d w = basis.inverse() * (p - screen[0]);
      const Eigen::Vector2d affine = w.x() * corner_uvs[c].cast<double>() + w.y() * corner_uvs[2].cast<double>();
      max_affine_error = std::max(max_affine_error, (affine - truth).cwiseAbs().maxCoeff());
      ++checked;
    }
  }
  REQUIRE(checked > 3000);
  REQUIRE(max_error < 1.0 / 256);
  REQUIRE(max_affine_error > 10.0 / 256);
}

// A tilted flat plane under a headlight shows ambient + diffuse cos(angle) per
// channel, plus the Blinn-Phong highlight specular cos(angle)^shininess (h = l
// when light and eye coincide).
TEST_CASE("render: Lambert and Blinn-Phong shading of a plane under a headlight", "[stages][unit]") {
  const PinholeCamera camera = TestCamera();
  const Eigen::Vector3d point(0, 0, 0.5), normal = Eigen::Vector3d(std::sin(0.7), 0.2, -std::cos(0.7)).normalized();
  const auto on_plane = [&](double u, double v) {
    const Eigen::Vector3d ray = Ray(camera, u, v);
    return Eigen::Vector3d(normal.dot(point) / normal.dot(ray) * ray);
  };
  TriangleMesh mesh;
  mesh.positions_C.resize(3, 4);
  const double margin = 10;
  const Eigen::Vector2d corners[4] = {{-margin, -margin},
                                      {camera.width + margin, -margin},
                                      {camera.width + margin, camera.height + margin},
                                      {-margin, camera.height + margin}};
  for (int i = 0; i < 4; ++i) mesh.positions_C.col(i) = on_plane(corners[i].x(), corners[i].y()).cast<float>();
  mesh.triangles.resize(3, 2);
  mesh.triangles << 0, 0, 1, 2, 2, 3;
  Material material;
  material.color = {0.9f, 0.5f, 0.3f};
  material.ambient = 0.1f;
  material.diffuse = 0.7f;
  material.specular = 0.3f;
  material.shininess = 20;
  material.specular_color = {1.0f, 0.8f, 0.6f};

  Rasterizer rasterizer(camera);
  rasterizer.Clear(Eigen::Vector3f::Zero());
  rasterizer.Draw(mesh, material, Light{}, 0);
  const cv::Mat color = rasterizer.Color();
  double min_cos = 1, max_cos = 0;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const Eigen::Vector3d p = on_plane(x, y);
      const double cos_angle = std::abs(normal.dot(p)) / p.norm();
      min_cos = std::min(min_cos, cos_angle);
      max_cos = std::max(max_cos, cos_angle);
      const cv::Vec3f bgr = color.at<cv::Vec3f>(y, x);
      for (int c = 0; c < 3; ++c) {
        const double truth = material.color[c] * (material.ambient + material.diffuse * cos_angle) +
                             material.specular * material.specular_color[c] * std::pow(cos_angle, material.shininess);
        INFO("pixel " << x << ", " << y << " channel " << c);
        REQUIRE_THAT(bgr[c], WithinAbs(truth, 1e-4));
      }
    }
  }
  REQUIRE(max_cos - min_cos > 0.3);  // the check spans a range of angles
}

// The same scene renders to the same bits with one thread and with two.
TEST_CASE("render: output is bit-identical for any number of threads", "[stages][unit]") {
  const PinholeCamera camera = TestCamera(200, 320, 240);
  const RandomScene scene = MakeRandomScene(camera, 5000, 11);  // more than one set-up block
  const auto render = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    Rasterizer rasterizer(camera, 2);
    rasterizer.Clear(Eigen::Vector3f(0.1f, 0.2f, 0.3f));
    rasterizer.Draw(scene.mesh, scene.material, Light{}, 3);
    return std::vector<cv::Mat>{rasterizer.Color(), rasterizer.ColorFull(), rasterizer.Depth(), rasterizer.ObjectIds()};
  };
  const std::vector<cv::Mat> one = render(1), two = render(2);
  for (std::size_t i = 0; i < one.size(); ++i) REQUIRE(BitIdentical(one[i], two[i]));
  REQUIRE(cv::countNonZero(one[3] == 3) > camera.width * camera.height);  // of 4 wh samples
}

// Color() is the box average of ColorFull()'s s x s samples, and the full
// camera places sub-pixel centres at s u + (s - 1)/2.
TEST_CASE("render: supersampled colour is the box average of the full image", "[stages][unit]") {
  const PinholeCamera camera = TestCamera(120, 64, 48);
  const int s = 3;
  const RandomScene scene = MakeRandomScene(camera, 300, 5);
  Rasterizer rasterizer(camera, s);
  rasterizer.Clear(Eigen::Vector3f(0.5f, 0.5f, 0.5f));
  rasterizer.Draw(scene.mesh, scene.material, Light{}, 0);
  const cv::Mat color = rasterizer.Color(), full = rasterizer.ColorFull();
  REQUIRE(color.size() == cv::Size(camera.width, camera.height));
  REQUIRE(full.size() == cv::Size(s * camera.width, s * camera.height));
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      for (int c = 0; c < 3; ++c) {
        double sum = 0;
        for (int dy = 0; dy < s; ++dy)
          for (int dx = 0; dx < s; ++dx) sum += full.at<cv::Vec3f>(s * y + dy, s * x + dx)[c];
        REQUIRE_THAT(color.at<cv::Vec3f>(y, x)[c], WithinAbs(sum / (s * s), 1e-6));
      }
    }
  }
  const PinholeCamera full_camera = rasterizer.FullCamera();
  // Pixel u spans [u - 1/2, u + 1/2]; its first and last sub-pixel centres sit 1/(2s) inside.
  const double u = 10, first = u - 0.5 + 0.5 / s, last = u + 0.5 - 0.5 / s;
  REQUIRE_THAT((first - camera.cx) * full_camera.fx / camera.fx + full_camera.cx, WithinAbs(s * u, 1e-12));
  REQUIRE_THAT((last - camera.cx) * full_camera.fx / camera.fx + full_camera.cx, WithinAbs(s * u + s - 1, 1e-12));
  REQUIRE_THAT(full_camera.fy, WithinAbs(s * camera.fy, 1e-12));
}

// A floor triangle reaching behind the camera is cut at the near plane, not
// dropped: exactly the floor points between near and the far corner are drawn,
// at the depth of the ray-floor intersection.
TEST_CASE("render: a triangle crossing the near plane is clipped and drawn in part", "[stages][unit]") {
  PinholeCamera camera = TestCamera(100);
  camera.near_m = 0.05;
  const double floor_y = 0.01;  // the near cut shows at row cy + fy floor_y / near = 79.5
  // (x, z) corners: two behind the camera, one 3 m ahead.
  const std::vector<Eigen::Vector2d> corners_xz = {{-2, -1}, {2, -1}, {0, 3}};
  TriangleMesh mesh;
  mesh.positions_C.resize(3, 3);
  for (int i = 0; i < 3; ++i) mesh.positions_C.col(i) = Eigen::Vector3f(corners_xz[i].x(), floor_y, corners_xz[i].y());
  mesh.triangles.resize(3, 1);
  mesh.triangles << 0, 1, 2;

  Rasterizer rasterizer(camera);
  rasterizer.Clear(Eigen::Vector3f::Zero());
  rasterizer.Draw(mesh, Unlit(), Light{}, 1);
  const cv::Mat ids = rasterizer.ObjectIds(), depth = rasterizer.Depth();

  // Expected coverage from the ray-floor intersection of each pixel centre.
  cv::Mat expected = cv::Mat::zeros(camera.height, camera.width, CV_8UC1);
  cv::Mat truth_z(camera.height, camera.width, CV_64FC1, cv::Scalar(0));
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const Eigen::Vector3d ray = Ray(camera, x, y);
      if (ray.y() <= 0) continue;
      const double z = floor_y / ray.y();
      truth_z.at<double>(y, x) = z;
      expected.at<uchar>(y, x) = z >= camera.near_m && InsideDistance(corners_xz, Eigen::Vector2d(ray.x() * z, z)) > 0;
    }
  }
  int drawn = 0;
  for (int y = 1; y + 1 < camera.height; ++y) {
    for (int x = 1; x + 1 < camera.width; ++x) {
      const bool is_drawn = ids.at<int>(y, x) == 1;
      drawn += is_drawn;
      // Where the 3x3 neighbourhood agrees, the pixel is clear of the boundary.
      const cv::Mat block = expected(cv::Rect(x - 1, y - 1, 3, 3));
      const int inside = cv::countNonZero(block);
      INFO("pixel " << x << ", " << y);
      if (inside == 9) {
        REQUIRE(is_drawn);
        REQUIRE_THAT(depth.at<float>(y, x), WithinAbs(truth_z.at<double>(y, x), 1e-5 * truth_z.at<double>(y, x)));
      } else if (inside == 0) {
        REQUIRE(!is_drawn);
      }
    }
  }
  REQUIRE(drawn > 1000);
  REQUIRE(ids.at<int>(85, 80) == -1);  // just past the near cut
  REQUIRE(ids.at<int>(75, 80) == 1);   // just before it
}

// Texture lookups wrap around in u (a closed surface's seam) and clamp in v (its poles).
TEST_CASE("render: texture sampling wraps in u and clamps in v", "[stages][unit]") {
  cv::Mat texture(2, 4, CV_8UC3, cv::Scalar(0, 0, 0));
  texture.at<cv::Vec3b>(0, 0) = cv::Vec3b(200, 0, 0);
  texture.at<cv::Vec3b>(0, 3) = cv::Vec3b(100, 0, 0);
  texture.at<cv::Vec3b>(1, 0) = cv::Vec3b(0, 0, 0);
  const TextureSampler sampler(texture);
  // u = 0 lies halfway between the centres of the last and first columns; v = 0 above row 0's centre.
  REQUIRE_THAT(sampler.Sample({0.0f, 0.0f})[0], WithinAbs(150.0 / 255, 1e-6));
  REQUIRE_THAT(sampler.Sample({1.0f, 0.0f})[0], WithinAbs(150.0 / 255, 1e-6));
  REQUIRE_THAT(sampler.Sample({0.125f, -0.5f})[0], WithinAbs(200.0 / 255, 1e-6));
  REQUIRE_THAT(sampler.Sample({0.125f, 0.5f})[0], WithinAbs(100.0 / 255, 1e-6));  // between rows 0 and 1
}

// The highlight's x^s agrees with std::pow over (0, 1] and the exponents in use, to
// 3e-7 (1 + |log2 x^s|) relative: float round-off of the exponent, amplified by its size.
TEST_CASE("render: PowUnit matches std::pow on the unit interval", "[stages][unit]") {
  for (float s : {0.0f, 1.0f, 4.5f, 32.0f, 200.0f}) {
    for (float x = 1.0f; x > 1e-6f; x *= 0.9993f) {
      const double truth = std::pow(static_cast<double>(x), static_cast<double>(s));
      INFO("x " << x << " s " << s);
      if (truth < 1e-30)
        REQUIRE(PowUnit(x, s) < 1e-30f);
      else
        REQUIRE_THAT(PowUnit(x, s), WithinAbs(truth, 3e-7 * (1 - std::log2(truth)) * truth));
    }
  }
  REQUIRE(PowUnit(0.0f, 2.0f) == 0.0f);
  REQUIRE(PowUnit(0.5f, 1000.0f) == 0.0f);  // 2^-1000 underflows
}

// Inconsistent input is rejected with a message naming the problem.
TEST_CASE("render: bad camera, mesh and material are rejected", "[stages][unit]") {
  const PinholeCamera camera = TestCamera();
  REQUIRE_THROWS_WITH(Rasterizer(camera, 0), Contains("supersample 0"));
  PinholeCamera no_focal = camera;
  no_focal.fx = 0;
  REQUIRE_THROWS_WITH(Rasterizer(no_focal), Contains("focal lengths"));

  Rasterizer rasterizer(camera);
  TriangleMesh mesh = MeshThroughPixels(camera, {{10, 10}, {50, 10}, {10, 50}}, 1.0, {{0, 1, 3}});
  REQUIRE_THROWS_WITH(rasterizer.Draw(mesh, Unlit(), Light{}, 0), Contains("refers to vertex 3"));
  mesh.triangles << 0, 1, 2;
  cv::Mat texture(4, 4, CV_8UC3, cv::Scalar(0, 0, 0));
  Material textured = Unlit();
  textured.texture = &texture;
  REQUIRE_THROWS_WITH(rasterizer.Draw(mesh, textured, Light{}, 0), Contains("without uvs"));
  cv::Mat gray(4, 4, CV_8UC1);
  textured.texture = &gray;
  mesh.uvs = Eigen::Matrix2Xf::Zero(2, 3);
  REQUIRE_THROWS_WITH(rasterizer.Draw(mesh, textured, Light{}, 0), Contains("CV_8UC3"));
}

}  // namespace dg::stages::render

namespace dg::stages::render {
namespace {

// A torus (closed, not convex: from an angle it hides parts of itself),
// tilted towards the camera, wound consistently.
TriangleMesh Torus(int around, int tube) {
  const double R = 0.02, r = 0.008;
  const Eigen::Isometry3d place = Eigen::Translation3d(0.003, -0.002, 0.1) * Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitX());
  TriangleMesh mesh;
  mesh.positions_C.resize(3, around * tube);
  mesh.triangles.resize(3, 2 * around * tube);
  const auto id = [&](int i, int j) { return (i % around) * tube + (j % tube); };
  for (int i = 0; i < around; ++i) {
    for (int j = 0; j < tube; ++j) {
      const double u = 2 * M_PI * i / around, v = 2 * M_PI * j / tube;
      mesh.positions_C.col(id(i, j)) =
          (place * Eigen::Vector3d((R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u),
                                   r * std::sin(v)))
              .cast<float>();
      const int t = 2 * id(i, j);
      mesh.triangles.col(t) << id(i, j), id(i + 1, j), id(i + 1, j + 1);
      mesh.triangles.col(t + 1) << id(i, j), id(i + 1, j + 1), id(i, j + 1);
    }
  }
  return mesh;
}

}  // namespace

// Skipping the triangles that face away from the eye leaves the image of a
// closed surface seen from outside unchanged to the bit, whichever way it is
// wound; an open or inconsistently wound surface is drawn two-sided.
TEST_CASE("render: a closed surface's back faces are skipped without changing the image", "[stages][unit]") {
  const PinholeCamera camera = TestCamera(200, 160, 120);
  TriangleMesh mesh = Torus(48, 24);
  if (GENERATE(false, true)) mesh.triangles.row(1).swap(mesh.triangles.row(2));  // the other winding
  const Eigen::Matrix3Xd vertices = mesh.positions_C.cast<double>();
  const TriangleMesh::Front front = SurfaceFront(vertices, mesh.triangles);
  REQUIRE(front != TriangleMesh::Front::kBoth);
  Eigen::Matrix3Xi flipped = mesh.triangles;
  flipped.row(1).swap(flipped.row(2));
  REQUIRE(SurfaceFront(vertices, flipped) != front);
  REQUIRE(SurfaceFront(vertices, flipped) != TriangleMesh::Front::kBoth);
  // Open (one triangle missing), or one triangle wound the other way: two-sided.
  REQUIRE(SurfaceFront(vertices, mesh.triangles.leftCols(mesh.triangles.cols() - 1)) == TriangleMesh::Front::kBoth);
  Eigen::Matrix3Xi inconsistent = mesh.triangles;
  inconsistent.col(7) = flipped.col(7);
  REQUIRE(SurfaceFront(vertices, inconsistent) == TriangleMesh::Front::kBoth);

  const auto render = [&](TriangleMesh::Front drawn_front) {
    TriangleMesh drawn = mesh;
    drawn.front = drawn_front;
    Rasterizer rasterizer(camera, 2);
    rasterizer.Clear(Eigen::Vector3f(0.1f, 0.2f, 0.3f));
    Material material;
    material.color = Eigen::Vector3f(0.9f, 0.6f, 0.4f);
    rasterizer.Draw(drawn, material, Light{}, 1);
    return std::vector<cv::Mat>{rasterizer.ColorFull(), rasterizer.Depth(), rasterizer.ObjectIds()};
  };
  const std::vector<cv::Mat> both = render(TriangleMesh::Front::kBoth), culled = render(front);
  for (std::size_t i = 0; i < both.size(); ++i) REQUIRE(BitIdentical(both[i], culled[i]));
  REQUIRE(cv::countNonZero(both[2] == 1) > 2000);  // the torus covers thousands of samples
  // Culling the wrong side shows the inside: the test can tell.
  const TriangleMesh::Front wrong =
      front == TriangleMesh::Front::kAlongNormal ? TriangleMesh::Front::kAgainstNormal : TriangleMesh::Front::kAlongNormal;
  REQUIRE_FALSE(BitIdentical(both[1], render(wrong)[1]));
}

}  // namespace dg::stages::render

namespace dg::stages::render {

// Clear() writes only what the draws since the last one touched, and the
// result is the same as a fresh rasterizer's: a large triangle, cleared,
// leaves nothing behind under a small one; a new background clears everything.
TEST_CASE("render: clearing only the drawn samples leaves no trace of the last frame", "[stages][unit]") {
  const PinholeCamera camera = TestCamera(200, 160, 120);
  const TriangleMesh large = MeshThroughPixels(camera, {{5, 5}, {150, 10}, {80, 110}}, 0.1, {{0, 1, 2}});
  const TriangleMesh small = MeshThroughPixels(camera, {{60, 50}, {90, 52}, {70, 80}}, 0.1, {{0, 1, 2}});
  Rasterizer reused(camera, 2), fresh(camera, 2);
  reused.Clear(Eigen::Vector3f::Zero());
  reused.Draw(large, Unlit(), Light{}, 1);
  const cv::Rect large_bounds = reused.DrawnSamples();
  CHECK(large_bounds.area() > 200 * 150);
  CHECK(large_bounds.area() < 320 * 240);
  for (const Eigen::Vector3f& background : {Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(0.2f, 0.1f, 0.3f)}) {
    reused.Clear(background);
    CHECK(reused.DrawnSamples().empty());
    reused.Draw(small, Unlit(), Light{}, 2);
    fresh.Clear(background);
    fresh.Draw(small, Unlit(), Light{}, 2);
    REQUIRE(BitIdentical(reused.ColorFull(), fresh.ColorFull()));
    REQUIRE(BitIdentical(reused.Depth(), fresh.Depth()));
    REQUIRE(BitIdentical(reused.ObjectIds(), fresh.ObjectIds()));
    CHECK((large_bounds & reused.DrawnSamples()) == reused.DrawnSamples());
    reused.Draw(large, Unlit(), Light{}, 1);  // the next round clears it again
  }
}

}  // namespace dg::stages::render
