#pragma once

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

namespace dg::io {

// Named fields on a mesh, for the .vtu and XDMF writers. Each matrix has one
// row per component (1 scalar, 3 vector, 6 symmetric tensor in the order
// xx yy zz xy yz xz, 9 full tensor row-major) and one column per node
// (point_data) or per element (cell_data). Names carry units (e.g. "stress_Pa").
struct MeshFields {
  std::vector<std::pair<std::string, Eigen::MatrixXd>> point_data;
  std::vector<std::pair<std::string, Eigen::MatrixXd>> cell_data;
};

// The writers' name for the nodal displacement; reserved in point_data.
inline constexpr char kDisplacementName[] = "displacement_m";

// Checks that every name is made of letters, digits, '_', '-' or '.' (safe in
// XML and as an HDF5 dataset name), is unique among the point (or cell) fields
// and is not kDisplacementName, and that each matrix has at least one row and
// num_nodes (or num_cells) columns.
// @throws dg::Error naming the field, with `where` (the file being written).
void CheckMeshFields(const MeshFields& fields, int num_nodes, int num_cells,
                     const std::string& where);

}  // namespace dg::io
