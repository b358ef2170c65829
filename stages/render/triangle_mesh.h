#pragma once

#include <string>

#include <Eigen/Core>

namespace dg::stages::render {

// A triangle mesh already placed in the camera frame C (x right, y down,
// z forward), metres. Triangles may wind either way: surfaces are two-sided,
// unless `front` says which side of a closed surface faces out.
struct TriangleMesh {
  // Which side of each triangle faces out, with n = (P1 - P0) x (P2 - P0):
  // for a closed surface wound consistently (SurfaceFront()), the rasterizer
  // then skips the triangles that face away from the eye, which from outside
  // the surface are always hidden behind those that face it: the same image
  // at half the triangles.
  enum class Front { kBoth, kAlongNormal, kAgainstNormal };
  Front front = Front::kBoth;

  Eigen::Matrix3Xf positions_C;  // one column per vertex
  Eigen::Matrix3Xf normals_C;    // per vertex, any length; empty: each triangle's own (flat) normal
  Eigen::Matrix2Xf uvs;          // per vertex texture coordinates: u right, v down (v = 0 the top row); may be empty
  Eigen::Matrix3Xi triangles;    // vertex ids

  // Empty if consistent (attribute counts match, ids in range), otherwise what is wrong.
  std::string Validate() const;
};

// Which side of a surface's triangles faces out: kAlongNormal or
// kAgainstNormal when every edge joins exactly two triangles that traverse it
// in opposite directions (closed, consistently wound) and the enclosed signed
// volume says which way; kBoth otherwise (open, or wound inconsistently).
TriangleMesh::Front SurfaceFront(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles);

}  // namespace dg::stages::render
