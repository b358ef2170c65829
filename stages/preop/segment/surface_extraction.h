#pragma once

#include <string>

#include "io/surface_mesh.h"
#include "stages/preop/segment/segmentation.h"

namespace dg::stages::preop {

// A closed triangulated surface from a voxel mask (the second step of the
// paper's section 2.4): VTK's flying edges at the mask's half level, windowed
// sinc smoothing (Taubin's low-pass filter: it removes the staircase without
// shrinking the surface as Laplacian smoothing does), then quadric edge
// collapse down to a triangle count fit for real-time simulation and drawing.
// The mask is padded with one empty voxel on every side, so a mask that
// touches the grid's edge still gives a closed surface.
struct SurfaceOptions {
  int smoothing_iterations = 20;
  // Windowed sinc pass band in (0, 2]: lower smooths more. 0.1 removes the
  // one-voxel staircase and keeps features of a few voxels.
  double smoothing_pass_band = 0.1;
  // Decimation stops at this many triangles (kept as is when flying edges give
  // fewer).
  int target_triangles = 5000;

  std::string Validate() const;  // empty when valid, else what is wrong
};

struct SurfaceReport {
  int extracted_triangles = 0;  // from flying edges, before decimation
  int triangles = 0;
  double enclosed_volume_m3 = 0;
};

// The surface of `mask` in the scan frame S, metres: each point mapped from
// voxel indices through the mask's origin, spacing and direction (VTK 9.1's
// image data has no direction). Triangles are counter-clockwise seen from
// outside whatever the direction's handedness. No normals, no uvs.
// @throws dg::Error for invalid options, or an empty mask.
io::SurfaceMesh ExtractSurface(const VoxelMask& mask, const SurfaceOptions& options, SurfaceReport* report = nullptr);

// Six times the signed volume enclosed by a closed triangle surface (positive
// when its triangles are counter-clockwise seen from outside).
double SixEnclosedVolume(const io::SurfaceMesh& surface);

}  // namespace dg::stages::preop
