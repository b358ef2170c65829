#pragma once

#include <Eigen/Core>

#include "sim/material.h"
#include "sim/tet_mesh.h"

namespace dg::sim {

// Deformation gradient of element e at displacement u (3 per node, metres):
// F = (current edge matrix) (reference edge matrix)^-1, in double.
template <typename T>
Eigen::Matrix3d DeformationGradient(const TetMesh& mesh, int e, const T* u);

// Per-element results for output and reports, in mesh element order.
struct ElementMeasures {
  Eigen::VectorXd volume_ratio;       // J = det F
  Eigen::VectorXd von_mises_pa;       // of the Cauchy stress J^-1 F S F^T
};

// Evaluates the neo-Hookean law (material.h) in double, element by element.
ElementMeasures ComputeElementMeasures(const TetMesh& mesh, const Material& material,
                                       const Eigen::Matrix3Xd& u_m);

}  // namespace dg::sim
