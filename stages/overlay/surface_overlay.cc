#include "stages/overlay/surface_overlay.h"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "sim/error.h"

namespace dg::stages::overlay {
namespace {

Eigen::Matrix3Xd AllVertices(const std::vector<OverlaySurface>& surfaces) {
  Eigen::Index count = 0;
  for (const OverlaySurface& s : surfaces) count += s.mesh.num_vertices();
  Eigen::Matrix3Xd vertices(3, count);
  Eigen::Index first = 0;
  for (const OverlaySurface& s : surfaces) {
    vertices.middleCols(first, s.mesh.num_vertices()) = s.mesh.vertices_m;
    first += s.mesh.num_vertices();
  }
  return vertices;
}

// Area-weighted vertex normals (the rasterizer normalises per sample).
void AccumulateNormals(const Eigen::Matrix3Xf& positions, const Eigen::Matrix3Xi& triangles, Eigen::Matrix3Xf* normals) {
  normals->setZero(3, positions.cols());
  for (Eigen::Index t = 0; t < triangles.cols(); ++t) {
    const Eigen::Vector3f a = positions.col(triangles(0, t));
    const Eigen::Vector3f area_normal = (positions.col(triangles(1, t)) - a).cross(positions.col(triangles(2, t)) - a);
    for (int k = 0; k < 3; ++k) normals->col(triangles(k, t)) += area_normal;
  }
}

const std::vector<OverlaySurface>& CheckedSurfaces(const std::vector<OverlaySurface>& surfaces) {
  if (surfaces.empty()) throw Error("no surfaces to draw", "overlay", "name at least one overlay mesh in the scene");
  for (const OverlaySurface& s : surfaces) {
    const std::string where = "overlay surface " + s.name;
    if (!s.texture.empty() && s.texture.type() != CV_8UC3)
      throw Error("the texture is not 8-bit, 3-channel", where, "save the texture as an 8-bit colour PNG");
    if (!s.texture.empty() && s.mesh.uvs.cols() != s.mesh.num_vertices())
      throw Error("a textured surface without per-vertex texture coordinates", where,
                  "export the mesh with texture coordinates (OBJ vt, PLY s t)");
  }
  return surfaces;
}

// The texture and its halvings (Gaussian-filtered, cv::pyrDown) down to a
// few texels: a level is the texture prefiltered for a surface drawn that
// many times smaller (mip-mapping).
std::vector<cv::Mat> TextureLevels(const cv::Mat& texture) {
  std::vector<cv::Mat> levels{texture};
  while (levels.back().cols >= 16 && levels.back().rows >= 16) {
    cv::Mat half;
    cv::pyrDown(levels.back(), half);
    levels.push_back(half);
  }
  return levels;
}

// The level whose texels are about one per sample where the surface is
// drawn: the texels its triangles span over the samples they cover (every
// 4th triangle, in front of the camera), as a power of 4. A textured surface
// drawn much smaller than its texture then samples a prefiltered level,
// which is both what the eye should see (no aliasing) and cache-friendly:
// sampling the full texture at a fraction of its density misses the cache
// on nearly every sample.
int TextureLevel(const render::TriangleMesh& drawn, const render::PinholeCamera& camera, cv::Size texture,
                 int levels) {
  constexpr int kEvery = 4;
  double texel_area = 0, sample_area = 0;
  for (Eigen::Index t = 0; t < drawn.triangles.cols(); t += kEvery) {
    Eigen::Vector2d pixel[3], uv[3];
    bool in_front = true;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3f p = drawn.positions_C.col(drawn.triangles(k, t));
      in_front = in_front && p.z() > camera.near_m;
      pixel[k] = {camera.fx * p.x() / p.z() + camera.cx, camera.fy * p.y() / p.z() + camera.cy};
      uv[k] = {drawn.uvs(0, drawn.triangles(k, t)) * texture.width, drawn.uvs(1, drawn.triangles(k, t)) * texture.height};
    }
    if (!in_front) continue;
    const auto area = [](const Eigen::Vector2d* c) {
      const Eigen::Vector2d a = c[1] - c[0], b = c[2] - c[0];
      return 0.5 * std::abs(a.x() * b.y() - a.y() * b.x());
    };
    sample_area += area(pixel);
    texel_area += area(uv);
  }
  if (!(sample_area > 0 && texel_area > sample_area)) return 0;
  return std::min(levels - 1, static_cast<int>(std::floor(0.5 * std::log2(texel_area / sample_area))));
}

const SurfaceOverlay::Options& CheckedOptions(const SurfaceOverlay::Options& options) {
  if (const std::string problem = options.Validate(); !problem.empty())
    throw Error("invalid surface overlay options: " + problem, "overlay options", "correct the scene's overlay settings");
  return options;
}

}  // namespace

std::string SurfaceOverlay::Options::Validate() const {
  if (!(opacity >= 0 && opacity <= 1)) return "opacity must be within [0, 1]";
  if (supersample < 1 || supersample > 4) return "supersample must be within [1, 4]";
  if (reserved_layers < 1) return "reserved_layers must be at least 1 (the layer being drawn)";
  return {};
}

std::shared_ptr<const sim::Embedding> SurfaceOverlay::Embed(const sim::TetMesh& mesh,
                                                            const std::vector<OverlaySurface>& surfaces) {
  return std::make_shared<const sim::Embedding>(mesh, AllVertices(CheckedSurfaces(surfaces)));
}

SurfaceOverlay::SurfaceOverlay(const Options& options, const sim::TetMesh& mesh, std::vector<OverlaySurface> surfaces,
                               const LensView& view)
    : SurfaceOverlay(options, Embed(mesh, surfaces), surfaces, view) {}

SurfaceOverlay::SurfaceOverlay(const Options& options, std::shared_ptr<const sim::Embedding> embedding,
                               std::vector<OverlaySurface> surfaces, const LensView& view)
    : options_(CheckedOptions(options)),
      surfaces_(CheckedSurfaces(surfaces)),
      embedding_(std::move(embedding)),
      view_(view),
      rasterizer_(view.pinhole(), options.supersample) {
  Eigen::Index vertices = 0;
  for (const OverlaySurface& s : surfaces_) vertices += s.mesh.num_vertices();
  if (!embedding_ || embedding_->num_points() != vertices) {
    throw Error("the embedding is not of the surfaces' " + std::to_string(vertices) + " vertices", "surface overlay",
                "embed the same surfaces (SurfaceOverlay::Embed)");
  }
  Eigen::Index first = 0;
  for (const OverlaySurface& s : surfaces_) {
    first_vertex_.push_back(first);
    first += s.mesh.num_vertices();
    render::TriangleMesh drawn;
    drawn.triangles = s.mesh.triangles;
    drawn.front = render::SurfaceFront(s.mesh.vertices_m, s.mesh.triangles);
    if (!s.texture.empty()) {
      drawn.uvs = s.mesh.uvs.cast<float>();
      drawn.uvs.row(1) = 1 - drawn.uvs.row(1).array();  // the rasterizer's v runs down the image
    }
    drawn_.push_back(std::move(drawn));
    texture_levels_.push_back(s.texture.empty() ? std::vector<cv::Mat>{} : TextureLevels(s.texture));
  }
  layers_.Reserve(options_.reserved_layers, {view.pinhole().width, view.pinhole().height});
}

OverlayLayer SurfaceOverlay::Process(const Eigen::Matrix3Xd& nodes_S, std::int64_t frame) {
  if (nodes_S.cols() != embedding_->num_nodes())
    throw Error("node positions for " + std::to_string(nodes_S.cols()) + " nodes, the mesh has " +
                    std::to_string(embedding_->num_nodes()),
                "overlay, frame " + std::to_string(frame), "pass the simulation mesh's current node positions");
  embedding_->Rebuild(nodes_S, &vertices_S_);
  view_.ToView(vertices_S_, &vertices_view_);
  rasterizer_.Clear(Eigen::Vector3f::Zero());
  for (size_t i = 0; i < surfaces_.size(); ++i) {
    const OverlaySurface& surface = surfaces_[i];
    render::TriangleMesh& drawn = drawn_[i];
    drawn.positions_C = vertices_view_.middleCols(first_vertex_[i], surface.mesh.num_vertices());
    if (options_.lit) AccumulateNormals(drawn.positions_C, drawn.triangles, &drawn.normals_C);
    render::Material material;
    if (!surface.texture.empty()) {
      const std::vector<cv::Mat>& levels = texture_levels_[i];
      material.texture = &levels[TextureLevel(drawn, rasterizer_.FullCamera(), surface.texture.size(),
                                              static_cast<int>(levels.size()))];
    }
    material.color = surface.color_bgr;
    if (options_.lit) {
      material.ambient = 0.25f;
      material.diffuse = 0.75f;
      material.specular = 0.3f;
    } else {
      material.ambient = 1.0f;
      material.diffuse = 0.0f;
    }
    rasterizer_.Draw(drawn, material, render::Light{}, static_cast<int>(i));
  }
  return LayerFromRender(rasterizer_, options_.opacity, frame, &layers_);
}

}  // namespace dg::stages::overlay
