#include "stages/render/triangle_mesh.h"

namespace dg::stages::render {

std::string TriangleMesh::Validate() const {
  const Eigen::Index n = positions_C.cols();
  if (normals_C.cols() != 0 && normals_C.cols() != n)
    return "normals_C has " + std::to_string(normals_C.cols()) + " columns for " + std::to_string(n) + " vertices";
  if (uvs.cols() != 0 && uvs.cols() != n)
    return "uvs has " + std::to_string(uvs.cols()) + " columns for " + std::to_string(n) + " vertices";
  for (Eigen::Index t = 0; t < triangles.cols(); ++t) {
    for (int k = 0; k < 3; ++k) {
      if (triangles(k, t) < 0 || triangles(k, t) >= n)
        return "triangle " + std::to_string(t) + " refers to vertex " + std::to_string(triangles(k, t)) +
               " of " + std::to_string(n);
    }
  }
  return {};
}

}  // namespace dg::stages::render
