#pragma once

#include <string>

#include <Eigen/Core>

namespace dg::stages::render {

// A triangle mesh already placed in the camera frame C (x right, y down,
// z forward), metres. Triangles may wind either way: surfaces are two-sided.
struct TriangleMesh {
  Eigen::Matrix3Xf positions_C;  // one column per vertex
  Eigen::Matrix3Xf normals_C;    // per vertex, any length; empty: each triangle's own (flat) normal
  Eigen::Matrix2Xf uvs;          // per vertex texture coordinates: u right, v down (v = 0 the top row); may be empty
  Eigen::Matrix3Xi triangles;    // vertex ids

  // Empty if consistent (attribute counts match, ids in range), otherwise what is wrong.
  std::string Validate() const;
};

}  // namespace dg::stages::render
