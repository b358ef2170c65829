#include "stages/render/triangle_mesh.h"

#include <algorithm>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

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

TriangleMesh::Front SurfaceFront(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles) {
  // Every directed edge once, and its reverse once: sorted keys, each edge
  // (a, b) beside (b, a) exactly when the surface is closed and consistently wound.
  std::vector<std::uint64_t> directed, reversed;
  directed.reserve(3 * triangles.cols());
  reversed.reserve(3 * triangles.cols());
  double six_volume = 0;
  for (Eigen::Index t = 0; t < triangles.cols(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const auto a = static_cast<std::uint64_t>(triangles(k, t)), b = static_cast<std::uint64_t>(triangles((k + 1) % 3, t));
      directed.push_back(a << 32 | b);
      reversed.push_back(b << 32 | a);
    }
    six_volume += vertices.col(triangles(0, t)).dot(vertices.col(triangles(1, t)).cross(vertices.col(triangles(2, t))));
  }
  std::sort(directed.begin(), directed.end());
  std::sort(reversed.begin(), reversed.end());
  const bool closed = triangles.cols() > 0 && directed == reversed &&
                      std::adjacent_find(directed.begin(), directed.end()) == directed.end();
  if (!closed || six_volume == 0) return TriangleMesh::Front::kBoth;
  return six_volume > 0 ? TriangleMesh::Front::kAlongNormal : TriangleMesh::Front::kAgainstNormal;
}

}  // namespace dg::stages::render
