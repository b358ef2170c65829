#pragma once

#include <string>

#include "sim/tet_mesh.h"

namespace dg::io {

// Reads a Gmsh mesh file, format 2.2 or 4.1, ASCII, into a checked TetMesh.
//
// - 4-node tetrahedra (Gmsh type 4) make the mesh. Points, lines and surface
//   elements are read only for their physical groups; any other volume element
//   (second-order tetrahedra, hexahedra, prisms, pyramids) is refused by name.
// - Node ids follow the order of the nodes in the file, whatever their tags
//   (Gmsh tags may be sparse); nodes no tetrahedron uses are dropped.
// - Every physical group becomes a node set (all nodes of its elements); a 3D
//   group also becomes an element set. Names come from $PhysicalNames; an
//   unnamed group is called "physical_<dim>_<tag>". Groups of different
//   dimensions that share a name share one node set.
// - Coordinates are multiplied by metres_per_unit (Gmsh files carry no unit).
// - Each tetrahedron keeps the file's element tag and the line that defines it
//   (element_tags, element_lines), so that messages name it as the file does.
// - Elements are oriented positively (OrientElements with kReorient).
//
// @throws dg::Error for a missing file, malformed or truncated content (where
//   is "path:line"), an unsupported format version or element type, or a mesh
//   without tetrahedra.
sim::TetMesh ReadGmsh(const std::string& path, double metres_per_unit = 1.0);

}  // namespace dg::io
