#include "stages/render/rasterizer.h"

#include <algorithm>
#include <limits>
#include <optional>

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "sim/error.h"
#include "stages/render/texture_sampler.h"

namespace dg::stages::render {
namespace {

// Far enough outside the image that the clipper's cut edges never show, small
// enough that projected coordinates stay below 2^15 pixels (triangle_setup.h).
constexpr double kGuardBandPx = 4096;
constexpr int kMaxFullSize = 16384;
// Input triangles set up per task; fixed, so block order is thread-independent.
constexpr int kSetupBlock = 2048;

}  // namespace

// Filled while rasterizing a tile, read when shading it: shading only the
// nearest surface per sample (not every triangle that passed the depth test on
// the way) is what makes overdraw cheap. Same result as shading immediately,
// since material and light are fixed within one Draw.
struct Rasterizer::TileSample {
  const ScreenTriangle* triangle;
  float b1, b2;  // perspective-correct barycentrics of vertices 1 and 2
};

struct Rasterizer::TileScratch : tbb::enumerable_thread_specific<std::vector<TileSample>> {
  TileScratch() : tbb::enumerable_thread_specific<std::vector<TileSample>>(kTileSize * kTileSize) {}
};

Rasterizer::Rasterizer(const PinholeCamera& camera, int supersample)
    : camera_(camera),
      full_camera_(camera.Supersampled(supersample)),
      supersample_(supersample),
      clipper_(full_camera_, kGuardBandPx),
      tile_samples_(std::make_shared<TileScratch>()) {
  if (const std::string problem = camera.Validate(); !problem.empty())
    throw Error("invalid camera: " + problem, "render::Rasterizer", "pass a calibrated pinhole camera");
  if (supersample < 1 || supersample > 8)
    throw Error("supersample " + std::to_string(supersample) + " is outside [1, 8]", "render::Rasterizer",
                "use 1 (none) to 4; more costs s^2 and gains little");
  if (full_camera_.width > kMaxFullSize || full_camera_.height > kMaxFullSize)
    throw Error("supersampled image " + std::to_string(full_camera_.width) + "x" +
                    std::to_string(full_camera_.height) + " exceeds " + std::to_string(kMaxFullSize) + " pixels",
                "render::Rasterizer", "lower the supersampling factor");
  tiles_x_ = (full_camera_.width + kTileSize - 1) / kTileSize;
  tiles_y_ = (full_camera_.height + kTileSize - 1) / kTileSize;
  bins_.resize(static_cast<std::size_t>(tiles_x_) * tiles_y_);
  color_full_.create(full_camera_.height, full_camera_.width, CV_32FC3);
  depth_full_.create(full_camera_.height, full_camera_.width, CV_32FC1);
  ids_full_.create(full_camera_.height, full_camera_.width, CV_32SC1);
  background_ = Eigen::Vector3f::Zero();
  drawn_ = cv::Rect(0, 0, full_camera_.width, full_camera_.height);
  Clear(background_);
}

void Rasterizer::Clear(const Eigen::Vector3f& background_bgr) {
  if (background_bgr != background_) drawn_ = cv::Rect(0, 0, full_camera_.width, full_camera_.height);
  background_ = background_bgr;
  color_full_(drawn_).setTo(cv::Scalar(background_bgr[0], background_bgr[1], background_bgr[2]));
  depth_full_(drawn_).setTo(std::numeric_limits<float>::infinity());
  ids_full_(drawn_).setTo(-1);
  drawn_ = cv::Rect();
}

void Rasterizer::Draw(const TriangleMesh& mesh, const Material& material, const Light& light, int object_id) {
  const auto where = [object_id] { return "render::Rasterizer::Draw, object " + std::to_string(object_id); };
  if (const std::string problem = mesh.Validate(); !problem.empty())
    throw Error("inconsistent mesh: " + problem, where(), "give every vertex a position (and a normal and uv, if any)");
  if (const std::string problem = material.Validate(); !problem.empty())
    throw Error("invalid material: " + problem, where(), "fix the material");
  if (material.texture != nullptr && mesh.uvs.cols() == 0)
    throw Error("textured material on a mesh without uvs", where(), "give the mesh per-vertex uvs or drop the texture");

  SetUpTriangles(mesh);
  BinTriangles();
  tbb::parallel_for(tbb::blocked_range<int>(0, tiles_x_ * tiles_y_), [&](const tbb::blocked_range<int>& range) {
    std::vector<TileSample>& samples = tile_samples_->local();
    for (int tile = range.begin(); tile != range.end(); ++tile) {
      if (!bins_[tile].empty()) RenderTile(tile, material, light, object_id, &samples);
    }
  });
}

void Rasterizer::SetUpTriangles(const TriangleMesh& mesh) {
  const int num_triangles = static_cast<int>(mesh.triangles.cols());
  const int num_blocks = (num_triangles + kSetupBlock - 1) / kSetupBlock;
  blocks_.resize(std::max<std::size_t>(blocks_.size(), num_blocks));
  for (auto& block : blocks_) block.clear();
  const bool smooth = mesh.normals_C.cols() != 0;
  const bool has_uvs = mesh.uvs.cols() != 0;
  const float facing = mesh.front == TriangleMesh::Front::kAlongNormal     ? 1.0f
                       : mesh.front == TriangleMesh::Front::kAgainstNormal ? -1.0f
                                                                           : 0.0f;
  tbb::parallel_for(0, num_blocks, [&](int b) {
    std::vector<ScreenTriangle>& out = blocks_[b];
    ClipPolygon polygon;
    const int end = std::min(num_triangles, (b + 1) * kSetupBlock);
    for (int t = b * kSetupBlock; t < end; ++t) {
      if (facing != 0) {
        // The eye at the origin sees the triangle's back: n . P0 > 0 for the outward n.
        const Eigen::Vector3f p0 = mesh.positions_C.col(mesh.triangles(0, t));
        const Eigen::Vector3f n = (mesh.positions_C.col(mesh.triangles(1, t)) - p0)
                                      .cross(mesh.positions_C.col(mesh.triangles(2, t)) - p0);
        if (facing * n.dot(p0) > 0) continue;
      }
      std::array<ClipVertex, 3> corners;
      for (int k = 0; k < 3; ++k) {
        const int id = mesh.triangles(k, t);
        corners[k].position_C = mesh.positions_C.col(id).cast<double>();
        corners[k].uv = has_uvs ? Eigen::Vector2f(mesh.uvs.col(id)) : Eigen::Vector2f::Zero();
        if (smooth) corners[k].normal_C = mesh.normals_C.col(id);
      }
      if (!smooth) {
        const Eigen::Vector3f normal_C =
            (corners[1].position_C - corners[0].position_C)
                .cross(corners[2].position_C - corners[0].position_C)
                .normalized()
                .cast<float>();
        for (auto& corner : corners) corner.normal_C = normal_C;
      }
      clipper_.Clip(corners, &polygon);
      AppendScreenTriangles(full_camera_, polygon, &out);
    }
  });
}

void Rasterizer::BinTriangles() {
  for (auto& bin : bins_) bin.clear();
  for (const auto& block : blocks_) {
    for (const ScreenTriangle& t : block) {
      drawn_ |= cv::Rect(t.min_x, t.min_y, t.max_x - t.min_x + 1, t.max_y - t.min_y + 1);
      for (int ty = t.min_y / kTileSize; ty <= t.max_y / kTileSize; ++ty) {
        for (int tx = t.min_x / kTileSize; tx <= t.max_x / kTileSize; ++tx) bins_[ty * tiles_x_ + tx].push_back(&t);
      }
    }
  }
}

void Rasterizer::RenderTile(int tile, const Material& material, const Light& light, int object_id,
                            std::vector<TileSample>* samples) {
  const int x0 = (tile % tiles_x_) * kTileSize, y0 = (tile / tiles_x_) * kTileSize;
  const int x1 = std::min(x0 + kTileSize, full_camera_.width) - 1;
  const int y1 = std::min(y0 + kTileSize, full_camera_.height) - 1;
  std::fill(samples->begin(), samples->begin() + (y1 - y0 + 1) * kTileSize, TileSample{nullptr, 0, 0});

  // Visibility: the depth test per sample, triangles in submission order.
  for (const ScreenTriangle* t : bins_[tile]) {
    const int min_x = std::max(x0, t->min_x), max_x = std::min(x1, t->max_x);
    const int min_y = std::max(y0, t->min_y), max_y = std::min(y1, t->max_y);
    if (min_x > max_x || min_y > max_y) continue;
    const EdgeFunction& e0 = t->edge[0];
    const EdgeFunction& e1 = t->edge[1];
    const EdgeFunction& e2 = t->edge[2];
    std::int64_t row0 = e0.At(min_x, min_y) + e0.bias;
    std::int64_t row1 = e1.At(min_x, min_y) + e1.bias;
    std::int64_t row2 = e2.At(min_x, min_y) + e2.bias;
    for (int y = min_y; y <= max_y; ++y, row0 += e0.step_y, row1 += e1.step_y, row2 += e2.step_y) {
      float* depth = depth_full_.ptr<float>(y);
      TileSample* sample_row = samples->data() + (y - y0) * kTileSize;
      std::int64_t f0 = row0, f1 = row1, f2 = row2;
      for (int x = min_x; x <= max_x; ++x, f0 += e0.step_x, f1 += e1.step_x, f2 += e2.step_x) {
        if ((f0 | f1 | f2) < 0) continue;
        const Eigen::Vector3d pixel(x, y, 1);
        const double d0 = t->ray_weight[0].dot(pixel);
        const double d1 = t->ray_weight[1].dot(pixel);
        const double d2 = t->ray_weight[2].dot(pixel);
        const double inv_sum = 1 / (d0 + d1 + d2);
        const float z = std::clamp(static_cast<float>(t->depth_numerator * inv_sum), t->min_z, t->max_z);
        if (!(z < depth[x])) continue;  // also rejects NaN
        depth[x] = z;
        // Clamped: a centre a hair outside the exact triangle (vertices are
        // snapped) has a weight slightly below zero, a nearly edge-on sliver wild ones.
        sample_row[x - x0] = {t, std::clamp(static_cast<float>(d1 * inv_sum), 0.0f, 1.0f),
                              std::clamp(static_cast<float>(d2 * inv_sum), 0.0f, 1.0f)};
      }
    }
  }

  // Shading of the samples this Draw won.
  std::optional<TextureSampler> texture;
  if (material.texture != nullptr) texture.emplace(*material.texture);
  const BlinnPhongShader shader(material, light);
  const float inv_fx = static_cast<float>(1 / full_camera_.fx), inv_fy = static_cast<float>(1 / full_camera_.fy);
  const float cx = static_cast<float>(full_camera_.cx), cy = static_cast<float>(full_camera_.cy);
  for (int y = y0; y <= y1; ++y) {
    const TileSample* sample_row = samples->data() + (y - y0) * kTileSize;
    const float* depth = depth_full_.ptr<float>(y);
    cv::Vec3f* color = color_full_.ptr<cv::Vec3f>(y);
    int* ids = ids_full_.ptr<int>(y);
    for (int x = x0; x <= x1; ++x) {
      const TileSample& s = sample_row[x - x0];
      if (s.triangle == nullptr) continue;
      const ScreenTriangle& t = *s.triangle;
      const float b0 = 1 - s.b1 - s.b2;
      const Eigen::Vector3f normal_C = b0 * t.normal_C[0] + s.b1 * t.normal_C[1] + s.b2 * t.normal_C[2];
      Eigen::Vector3f albedo = Eigen::Vector3f::Ones();
      if (texture) albedo = texture->Sample(b0 * t.uv[0] + s.b1 * t.uv[1] + s.b2 * t.uv[2]);
      const float z = depth[x];
      const Eigen::Vector3f point_C((x - cx) * inv_fx * z, (y - cy) * inv_fy * z, z);
      const Eigen::Vector3f bgr = shader.Shade(albedo, normal_C, point_C);
      color[x] = cv::Vec3f(bgr[0], bgr[1], bgr[2]);
      ids[x] = object_id;
    }
  }
}

cv::Mat Rasterizer::Color() const {
  if (supersample_ == 1) return color_full_.clone();
  const int s = supersample_;
  const float inv_count = 1.0f / static_cast<float>(s * s);
  cv::Mat color(camera_.height, camera_.width, CV_32FC3);
  tbb::parallel_for(0, camera_.height, [&](int y) {
    cv::Vec3f* out = color.ptr<cv::Vec3f>(y);
    for (int x = 0; x < camera_.width; ++x) {
      cv::Vec3f sum(0, 0, 0);
      for (int dy = 0; dy < s; ++dy) {
        const cv::Vec3f* in = color_full_.ptr<cv::Vec3f>(y * s + dy) + x * s;
        for (int dx = 0; dx < s; ++dx) sum += in[dx];
      }
      out[x] = sum * inv_count;
    }
  });
  return color;
}

cv::Mat Rasterizer::ColorFull() const { return color_full_.clone(); }
cv::Mat Rasterizer::Depth() const { return depth_full_.clone(); }
cv::Mat Rasterizer::ObjectIds() const { return ids_full_.clone(); }

}  // namespace dg::stages::render
