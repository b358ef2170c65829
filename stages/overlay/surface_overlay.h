#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "io/surface_mesh.h"
#include "sim/embedding.h"
#include "sim/tet_mesh.h"
#include "stages/overlay/lens_view.h"
#include "stages/overlay/overlay_layer.h"
#include "stages/render/rasterizer.h"

namespace dg::stages::overlay {

// A surface an overlay draws: a triangle mesh in the scan frame at the
// reference configuration of the simulation mesh, and how it looks.
struct OverlaySurface {
  io::SurfaceMesh mesh;         // uvs (OBJ convention, v up) needed when textured
  cv::Mat texture;              // CV_8UC3 BGR; empty: the colour alone
  Eigen::Vector3f color_bgr{1, 1, 1};
  std::string name;             // for error messages (the file it came from)
};

// The embedded-mesh and surface-texture overlays (paper section 2.7): the
// vertices of high-resolution surfaces are embedded once in the simulation
// mesh (sim::Embedding); per frame they are rebuilt from the current node
// positions and drawn, depth-tested across all surfaces, through the
// calibrated lens (LensView), into a premultiplied layer.
//  - Embedded meshes (segmented anatomy): lit, Blinn-Phong under a headlight,
//    each surface in its colour.
//  - Surface texture (landmarks, annotations on the organ's surface): unlit,
//    the texture's own colours, to be alpha-blended with the video; sampled
//    from the mip level that matches the surface's size in the image.
// Process() reuses the rasterizer's buffers: one call at a time per instance
// (the pipeline runs each overlay serially, on its own rate).
class SurfaceOverlay {
 public:
  struct Options {
    float opacity = 0.6f;  // of the layer where the surfaces cover a pixel fully
    bool lit = true;       // false: texture or colour as is
    int supersample = 2;   // samples per pixel per axis, for smooth edges
    // Layers allocated up front: as many as are ever alive at once (those the
    // caller still holds, and the one being drawn), so that Process()
    // allocates none.
    int reserved_layers = 1;
    // Empty when valid; otherwise what is wrong.
    std::string Validate() const;
  };

  // @throws dg::Error for invalid options, an empty surface list, a textured
  //   surface without uvs, or a texture that is not 8-bit BGR.
  SurfaceOverlay(const Options& options, const sim::TetMesh& mesh, std::vector<OverlaySurface> surfaces,
                 const LensView& view);
  // The same with the surfaces' vertices embedded already (Embed()): the
  // embedding does not depend on the view, so a pipeline embeds once, before
  // the registration, and builds each eye's overlay from it when the pose is known.
  // @throws dg::Error as above, or for an embedding of other vertices.
  SurfaceOverlay(const Options& options, std::shared_ptr<const sim::Embedding> embedding,
                 std::vector<OverlaySurface> surfaces, const LensView& view);

  // Every surface's vertices, concatenated in surface order, embedded in the mesh.
  // @throws dg::Error for an empty surface list.
  static std::shared_ptr<const sim::Embedding> Embed(const sim::TetMesh& mesh,
                                                     const std::vector<OverlaySurface>& surfaces);

  // The layer for node positions nodes_S (scan frame, one column per node of
  // the mesh given to the constructor) of frame `frame`.
  // @throws dg::Error if nodes_S has the wrong number of columns.
  OverlayLayer Process(const Eigen::Matrix3Xd& nodes_S, std::int64_t frame);

  // Every surface's vertices, concatenated in surface order.
  const sim::Embedding& embedding() const { return *embedding_; }
  const LensView& view() const { return view_; }

 private:
  Options options_;
  std::vector<OverlaySurface> surfaces_;
  std::vector<Eigen::Index> first_vertex_;  // of each surface in the embedding
  std::vector<render::TriangleMesh> drawn_;  // per surface, reused every frame
  // Per textured surface, its texture and halvings (mip levels); empty for an untextured one.
  std::vector<std::vector<cv::Mat>> texture_levels_;
  LayerPool layers_;
  std::shared_ptr<const sim::Embedding> embedding_;
  LensView view_;
  render::Rasterizer rasterizer_;
  Eigen::Matrix3Xd vertices_S_;
  Eigen::Matrix3Xf vertices_view_;
};

}  // namespace dg::stages::overlay
