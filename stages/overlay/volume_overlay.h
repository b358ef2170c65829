#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/metaimage.h"
#include "sim/tet_mesh.h"
#include "stages/overlay/lens_view.h"
#include "stages/overlay/overlay_layer.h"
#include "stages/overlay/transfer_function.h"
#include "stages/render/clipping.h"
#include "stages/render/triangle_setup.h"

namespace dg::stages::overlay {

// The deformed CT volume, drawn as the paper does (section 2.7): every
// tetrahedron of the current geometry is cut by planes perpendicular to the
// viewing axis (z = const in the camera frame, shared by all elements, evenly
// spaced over the mesh's depth), each cut polygon samples the CT at the
// reference positions its corners map to (linear within the element: the
// element's own deformation inverted), and the slices are alpha-composited
// back to front:
//   C <- a c + (1 - a) C,  A <- a + (1 - a) A,  a = 1 - exp(-sigma(hu) ds),
// with (c, sigma) = transfer function(CT trilinear at the reference point) and
// ds the slice spacing along the pixel's true ray (spacing x |ray| / z).
// A constant-density slab of thickness L thus gets opacity 1 - exp(-sigma L)
// for any slice spacing, up to the slices' sampling of its ends.
//
// Software, like the rest of the rendering: cut
// polygons become screen triangles through the rasterizer's clipper and
// fixed-point set-up (watertight: neighbouring elements' cuts share edges
// exactly, so no pixel is composited twice per slice), binned to 64 x 64
// tiles, tiles composited in parallel, each pixel's slices in a fixed order:
// the image does not depend on the number of threads. Process() reuses
// buffers: one call at a time per instance.
class VolumeOverlay {
 public:
  struct Options {
    double slice_spacing_m = 0.5e-3;
    // Drawn at 1/divisor of the camera's resolution per axis and resampled
    // bilinearly to it (a volume's colour varies smoothly across the image:
    // 2 costs a quarter of the samples). Divides the image's width and height.
    int resolution_divisor = 1;
    float opacity = 1.0f;  // scales the whole layer
    // Layers allocated up front, as SurfaceOverlay::Options::reserved_layers.
    int reserved_layers = 1;
    // Empty when valid; otherwise what is wrong.
    std::string Validate() const;
  };

  // ct: the CT phase whose geometry is the mesh's reference configuration
  // (scan frame); shared, not copied: a stereo run draws it once per eye.
  // @throws dg::Error for invalid options or transfer function, a resolution
  //   divisor that does not divide the image, or a CT missing or smaller than
  //   2 voxels along an axis.
  VolumeOverlay(const Options& options, const sim::TetMesh& mesh, std::shared_ptr<const io::VolumeI16> ct,
                const TransferFunction& transfer, const LensView& view);

  // @throws dg::Error if nodes_S has the wrong number of columns.
  OverlayLayer Process(const Eigen::Matrix3Xd& nodes_S, std::int64_t frame);

  // Of the last Process(): slices through the mesh, and cut triangles drawn.
  int last_slices() const { return last_slices_; }
  std::size_t last_triangles() const { return last_triangles_; }

 private:
  static constexpr int kTileSize = 64;
  static constexpr int kLutSize = 4096;  // HU -1024 .. 3071
  struct Classified {
    float b, g, r, sigma_per_m;
  };
  // A cut triangle ready to composite: coverage from the rasterizer's set-up,
  // CT voxel coordinates affine over the image (exact on a plane z = const).
  struct SliceTriangle {
    render::ScreenTriangle screen;
    Eigen::Vector3f voxel_at_min;  // at pixel (screen.min_x, screen.min_y)
    Eigen::Vector3f voxel_dx, voxel_dy;
    int slice;
  };

  void CutElements(double z_first, double spacing, int slices);
  void BinTriangles();
  void CompositeTile(int tile, float spacing, cv::Mat* bgra) const;
  float SampleHu(const Eigen::Vector3f& voxel) const;

  Options options_;
  int num_nodes_;
  Eigen::Matrix<int, 4, Eigen::Dynamic> tets_;
  Eigen::Matrix3Xf voxel_nodes_;  // reference node positions in CT voxel coordinates
  std::shared_ptr<const io::VolumeI16> ct_;
  std::array<Classified, kLutSize> lut_;
  LensView view_;
  render::PinholeCamera camera_;  // the view's pinhole at 1/resolution_divisor of its resolution
  cv::Mat ray_length_;  // per pixel of camera_, |ray| / z
  cv::Mat reduced_;     // CV_32FC4 at camera_'s size when resolution_divisor > 1, resampled into the layer
  render::FrustumClipper clipper_;
  int tiles_x_, tiles_y_;

  Eigen::Matrix3Xd nodes_view_;
  std::vector<std::vector<SliceTriangle>> blocks_;
  std::vector<const SliceTriangle*> ordered_;
  std::vector<std::vector<const SliceTriangle*>> bins_;
  LayerPool layers_;
  int last_slices_ = 0;
  std::size_t last_triangles_ = 0;
};

}  // namespace dg::stages::overlay
