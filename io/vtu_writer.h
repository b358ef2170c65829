#pragma once

#include <Eigen/Core>
#include <string>

#include "io/mesh_fields.h"
#include "sim/tet_mesh.h"

namespace dg::io {

// Writes a TetMesh as a VTK XML unstructured grid (.vtu, version 1.0, binary
// appended raw data, little-endian, 64-bit headers) that ParaView and VTK open.
// Points are the reference positions X_m; when displacement_m is given it is
// written as the point vector field "displacement_m", so ParaView's "Warp By
// Vector" shows the deformed shape. Fields are written as named point and cell
// data with as many components as their matrices have rows.
// @throws dg::Error when the file cannot be written, displacement_m has not one
//   column per node, or a field is misnamed or of the wrong size (CheckMeshFields).
void WriteVtu(const std::string& path, const sim::TetMesh& mesh,
              const Eigen::Matrix3Xd* displacement_m, const MeshFields& fields);

}  // namespace dg::io
