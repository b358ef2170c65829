#pragma once

#include "sim/tet_mesh.h"

namespace dg::sim::testing {

// A box [0, size] of nx * ny * nz cubes, each split into six tetrahedra around
// its main diagonal (Kuhn), so the mesh is conforming. With jitter > 0 the
// interior nodes move by up to jitter * cell size in each axis (seeded), which
// makes the elements irregular while the boundary stays planar.
// Node sets "xmin", "xmax", "ymin", "ymax", "zmin", "zmax" hold the faces' nodes.
TetMesh MakeBoxMesh(int nx, int ny, int nz, const Eigen::Vector3d& size_m, double jitter = 0.0,
                    unsigned seed = 1);

}  // namespace dg::sim::testing
