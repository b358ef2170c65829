#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "stages/render/clipping.h"
#include "stages/render/pinhole_camera.h"
#include "stages/render/shading.h"
#include "stages/render/triangle_mesh.h"
#include "stages/render/triangle_setup.h"

namespace dg::stages::render {

// A z-buffered software rasterizer for one pinhole camera, used by the phantom
// generator and the overlay stages.
//
// Renders internally at supersample x the camera's resolution (buffers of
// FullCamera()); Color() box-filters down. Per sample: depth test on z
// (strictly nearer wins, so among equal depths the first drawn stays),
// perspective-correct uv and normals, bilinear texture, Blinn-Phong
// (shading.h). Coverage is exact: pixel centres at integer coordinates,
// vertices snapped to 1/256 pixel, the top-left rule on shared edges.
//
// Threading: Draw() bins triangles to 64 x 64 tiles and runs the tiles in
// parallel with TBB, each tile taking its triangles in submission order, so
// the output is bit-identical for any number of threads. A Rasterizer is not
// itself thread-safe: one caller at a time, one Rasterizer per view.
class Rasterizer {
 public:
  // Buffers are allocated here and reused by every frame.
  // @throws dg::Error if the camera is invalid, supersample is outside [1, 8],
  //   or the supersampled image is wider or taller than 16384 pixels.
  explicit Rasterizer(const PinholeCamera& camera, int supersample = 1);

  // Colour to background_bgr, depth to +inf, object ids to -1. Only the
  // samples drawn since the last Clear() are written, unless the background
  // changed: an organ covering part of the image costs that part.
  void Clear(const Eigen::Vector3f& background_bgr);

  // The supersampled samples that Draw() may have written since the last
  // Clear() (the union of the drawn triangles' bounds); outside it every
  // sample is the background.
  const cv::Rect& DrawnSamples() const { return drawn_; }

  // Draws the mesh's triangles (in the camera frame), writing object_id where
  // they are nearest. A textured material needs the mesh's uvs.
  // @throws dg::Error if the mesh or material is inconsistent.
  void Draw(const TriangleMesh& mesh, const Material& material, const Light& light, int object_id);

  // CV_32FC3 BGR at the camera's resolution: the mean of each pixel's s x s samples.
  cv::Mat Color() const;
  // CV_32FC3 BGR at the supersampled resolution, for callers that resample it
  // (lens distortion). A copy, like the two below.
  cv::Mat ColorFull() const;
  // CV_32FC1 z in metres at the supersampled resolution, +inf where nothing was drawn.
  cv::Mat Depth() const;
  // CV_32SC1 object ids at the supersampled resolution, -1 where nothing was drawn.
  cv::Mat ObjectIds() const;
  // The supersampled colour (CV_32FC3) and ids, not copied: valid until the next Clear() or Draw().
  const cv::Mat& ColorSamples() const { return color_full_; }
  const cv::Mat& ObjectIdSamples() const { return ids_full_; }

  const PinholeCamera& camera() const { return camera_; }
  // The camera of the supersampled buffers: PinholeCamera::Supersampled(s).
  const PinholeCamera& FullCamera() const { return full_camera_; }
  int supersample() const { return supersample_; }

 private:
  static constexpr int kTileSize = 64;
  struct TileSample;   // the nearest triangle so far at one sample of a tile
  struct TileScratch;  // each thread's tile of samples

  void SetUpTriangles(const TriangleMesh& mesh);
  void BinTriangles();
  void RenderTile(int tile, const Material& material, const Light& light, int object_id,
                  std::vector<TileSample>* samples);

  PinholeCamera camera_;
  PinholeCamera full_camera_;
  int supersample_;
  FrustumClipper clipper_;
  int tiles_x_, tiles_y_;

  Eigen::Vector3f background_;
  cv::Rect drawn_;      // DrawnSamples()
  cv::Mat color_full_;  // CV_32FC3
  cv::Mat depth_full_;  // CV_32FC1
  cv::Mat ids_full_;    // CV_32SC1

  // Per Draw, kept to reuse their memory: screen triangles set up from fixed
  // blocks of input triangles (fixed so that the order never depends on the
  // threads), and per tile the triangles touching it, in submission order.
  std::vector<std::vector<ScreenTriangle>> blocks_;
  std::vector<std::vector<const ScreenTriangle*>> bins_;
  // A tile's samples per thread (kTileSize^2 of them, 64 kB), kept from
  // Draw to Draw instead of made per task. Shared by copies: a thread renders
  // one tile at a time (no waits inside one).
  std::shared_ptr<TileScratch> tile_samples_;
};

}  // namespace dg::stages::render
