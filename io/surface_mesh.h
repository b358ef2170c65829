#pragma once

#include <string>

#include <Eigen/Core>

namespace dg::io {

// A triangulated surface: overlay meshes, the phantom's textured skin.
// Texture coordinates and normals are per vertex (a vertex on a texture seam
// is duplicated), each either empty or with one column per vertex. (u, v) is
// in OBJ's and PLY's convention: (0, 0) the bottom-left corner of the image,
// v upwards, so image row = (1 - v) * height.
struct SurfaceMesh {
  Eigen::Matrix3Xd vertices_m;
  Eigen::Matrix3Xi triangles;  // vertex indices, counter-clockwise seen from outside
  Eigen::Matrix2Xd uvs;
  Eigen::Matrix3Xd normals;

  int num_vertices() const { return static_cast<int>(vertices_m.cols()); }
  int num_triangles() const { return static_cast<int>(triangles.cols()); }
};

// OBJ and PLY files carry no units. Coordinates in the file are
// vertices_m / metres_per_unit: 1 (the default) for files in metres, 1e-3 for
// files in millimetres (a scene says which: MetresPerUnit(unit) in io/units.h).
struct SurfaceFileOptions {
  double metres_per_unit = 1.0;
  // OBJ only: an image (a path relative to the .obj) to show on the surface.
  // When given, a .mtl of the same stem is written beside the .obj with one
  // material whose diffuse map is the image, so that Blender, ParaView and
  // 3D Slicer show the texture.
  std::string texture_image;
};

// Writes Wavefront OBJ: v, vt and vn lines (the latter two when the mesh has
// them) and one `f a/a/a ...` line per triangle.
// @pre the mesh is valid: indices in range, uvs and normals empty or per vertex.
// @throws dg::Error when a file cannot be written.
void WriteObj(const std::string& path, const SurfaceMesh& mesh,
              const SurfaceFileOptions& options = {});

// Reads the geometry of an OBJ file: v, vt, vn and f lines with the index forms
// v, v/vt, v//vn, v/vt/vn, negative (relative) indices included; polygons are
// split into triangle fans. Other statements (o, g, s, usemtl, mtllib, l, ...)
// are ignored. Texture coordinates and normals are kept when every face
// corner has them.
// @throws dg::Error naming file:line of a malformed line or an index out of range.
SurfaceMesh ReadObj(const std::string& path, const SurfaceFileOptions& options = {});

// Writes binary little-endian PLY: vertex x y z (double), nx ny nz and s t
// (float) when the mesh has them; face vertex_indices (uchar count, int indices).
// @pre the mesh is valid. @throws dg::Error when the file cannot be written.
void WritePly(const std::string& path, const SurfaceMesh& mesh,
              const SurfaceFileOptions& options = {});

// Reads ASCII and binary little-endian PLY: any scalar types; vertex x y z,
// nx ny nz and texture coordinates named s t, u v or texture_u texture_v;
// faces as a vertex_indices (or vertex_index) list, fan-triangulated; other
// elements and properties skipped.
// @throws dg::Error naming file:line (header and ASCII body) or the element
//   (binary body) of what is malformed, missing or out of range.
SurfaceMesh ReadPly(const std::string& path, const SurfaceFileOptions& options = {});

}  // namespace dg::io
