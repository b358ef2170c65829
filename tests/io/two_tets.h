#pragma once

#include "sim/tet_mesh.h"

namespace dg::io::testing {

// Two tetrahedra sharing the face (1, 2, 3): the smallest mesh with an interior face.
inline sim::TetMesh TwoTets() {
  sim::TetMesh mesh;
  mesh.source = "two tets";
  mesh.X_m.resize(3, 5);
  mesh.X_m << 0, 1, 0, 0, 1,  //
      0, 0, 1, 0, 1,          //
      0, 0, 0, 1, 1;
  mesh.tets.resize(4, 2);
  mesh.tets << 0, 1,  //
      1, 3,           //
      2, 2,           //
      3, 4;
  return mesh;
}

}  // namespace dg::io::testing
