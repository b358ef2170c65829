#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "sim/material.h"
#include "sim/tet_mesh.h"

namespace dg::sim {

// The central-difference stability limit of a mesh, two ways.
//
// Assembled: dt_cr = 2 / omega_max with omega_max^2 the largest eigenvalue of
// M^-1 K (lumped M, tangent K at the reference state, constrained degrees of
// freedom removed), found by Lanczos iteration on M^-1/2 K M^-1/2 with K applied
// matrix-free as a central difference of the internal forces. This is the
// limit the undamped scheme really has (mass-proportional damping does not lower it).
//
// Per element: min_e L_e / c, L_e the element's smallest altitude and c the
// dilatational wave speed: cheap but conservative, about half the assembled
// limit on good meshes.
struct StabilityReport {
  double omega_max_rad_s = 0;
  double dt_critical_s = 0;        // 2 / omega_max
  double dt_element_bound_s = 0;   // min_e L_e / c
  int limiting_element = -1;       // the element setting the per-element bound
  int limiting_node = -1;          // where the highest mode has its largest amplitude
  Eigen::Vector3d limiting_node_position_m = Eigen::Vector3d::Zero();
  int lanczos_iterations = 0;
  double relative_residual = 0;    // Ritz residual of omega_max^2, relative

  // One line: both limits in ms, where, and how converged.
  std::string Describe() const;
};

// @param constrained_dofs degrees of freedom (3 node + axis) held by boundary conditions.
// @throws dg::Error for an invalid material or mesh.
StabilityReport EstimateStability(const TetMesh& mesh, const Material& material,
                                  const std::vector<int>& constrained_dofs);

}  // namespace dg::sim
