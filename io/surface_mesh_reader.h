#pragma once

#include <string>

#include "io/surface_mesh.h"

namespace dg::io {

// The surface mesh formats a user's file may be in, by extension (any case):
// .obj (ReadObj), .ply (ReadPly: ASCII or binary little-endian), and, through
// VTK's readers, .stl (ASCII or binary), .vtk (legacy VTK polydata) and .vtp
// (VTK XML polydata). PLY keeps its own reader: VTK 9.1's crashes on a file
// cut short and reads positions in single precision.
bool IsSurfaceMeshFile(const std::string& path);

// The accepted extensions, for messages: ".obj, .ply, .stl, .vtk or .vtp".
const std::string& SurfaceMeshExtensions();

// Reads a user's surface mesh in any accepted format, its coordinates scaled
// by options.metres_per_unit. Polygons and triangle strips are split into
// triangles, lines and points dropped. Per-vertex normals and texture
// coordinates are kept where the file has them: OBJ's vn and vt; PLY's nx ny nz
// and s t (or u v, texture_u texture_v); a VTK file's active normals and texture
// coordinates. STL has neither (its facet normals are not per vertex); its
// corners are merged into shared vertices.
// @throws dg::Error naming the file: an unknown extension (with the accepted
//   ones), a file that cannot be opened or parsed, one that holds no triangle,
//   or a coordinate that is not finite.
SurfaceMesh ReadSurfaceMesh(const std::string& path, const SurfaceFileOptions& options = {});

}  // namespace dg::io
