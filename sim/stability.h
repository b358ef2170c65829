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
  std::string limiting_element_name;  // as the user finds it (ElementName: the file's tag and line)
  int limiting_node = -1;          // where the highest mode has its largest amplitude
  Eigen::Vector3d limiting_node_position_m = Eigen::Vector3d::Zero();
  int lanczos_iterations = 0;
  double relative_residual = 0;    // Ritz residual of omega_max^2, relative

  // One line: both limits in ms, where, and how converged.
  std::string Describe() const;
  // "time step X ms exceeds S x the critical time step ..." when dt_s is above
  // safety * dt_critical_s, else empty.
  std::string TimeStepExcess(double dt_s, double safety) const;
};

// The fraction of the estimated dt_cr a step may take, by Poisson's ratio.
// The estimate is the reference state's; deformation stiffens the material,
// most where it is nearly incompressible. The project's stability study
// (docs/solver.md) ran every cell below 0.9 dt_cr for nu <= 0.45, failed one
// cell in 40 at 0.82 dt_cr for nu = 0.49, and failed every cell between 0.7
// and 0.9 dt_cr for nu = 0.499 while all below 0.7 ran. So: 0.9 up to nu =
// 0.45, 0.65 from nu = 0.499, and in between linear in log10(1 - 2 nu), the
// quantity the bulk modulus grows with (0.80 at nu = 0.49).
double DefaultStabilitySafety(double poissons_ratio);

// @param constrained_dofs degrees of freedom (3 node + axis) held by boundary conditions.
// @throws dg::Error for an invalid material or mesh.
StabilityReport EstimateStability(const TetMesh& mesh, const Material& material,
                                  const std::vector<int>& constrained_dofs);

}  // namespace dg::sim
