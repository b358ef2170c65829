#pragma once

#include <Eigen/Core>

#include "io/surface_mesh.h"

namespace dg::tools::preop {

// Texture coordinates for a user's annotation image on the organ's surface: a
// projection along the scan frame's z axis onto the surface's bounding box in
// x and y, u from min x to max x and v from min y to max y. Both sides of the
// organ get the same image; an annotation drawn on a view of the organ from
// along z (an axial maximum projection, say) lands where it was drawn.
Eigen::Matrix2Xd PlanarUvs(const io::SurfaceMesh& surface);

}  // namespace dg::tools::preop
