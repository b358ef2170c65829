// Uses the installed dg::sim: a 1 cm cube of six tetrahedra pulled to a small
// axial strain with free lateral faces, relaxed to rest. Prints the top face's
// nominal stress and Hooke's law's E * strain (exact here: linear tetrahedra
// represent the uniform strain exactly, and at 1e-4 the neo-Hookean material
// is linear to that order).
#include <cstdio>
#include <memory>
#include <vector>

#include "sim/error.h"
#include "sim/material.h"
#include "sim/stability.h"
#include "sim/tet_mesh.h"
#include "sim/tled_model.h"
#include "sim/tled_solver.h"

namespace {

constexpr double kSide_m = 0.01;

// Node i + 2 j + 4 k at (i, j, k) * side; six tetrahedra around the diagonal 0-7.
dg::sim::TetMesh UnitCube() {
  dg::sim::TetMesh mesh;
  mesh.source = "consumer cube";
  mesh.X_m.resize(3, 8);
  for (int n = 0; n < 8; ++n) mesh.X_m.col(n) = kSide_m * Eigen::Vector3d(n & 1, (n >> 1) & 1, (n >> 2) & 1);
  mesh.tets.resize(4, 6);
  mesh.tets << 0, 0, 0, 0, 0, 0,  //
      1, 1, 2, 2, 4, 4,           //
      3, 5, 3, 6, 5, 6,           //
      7, 7, 7, 7, 7, 7;
  dg::sim::OrientElements(&mesh);
  return mesh;
}

}  // namespace

int main() {
  try {
    const dg::sim::TetMesh mesh = UnitCube();
    const dg::sim::Material material{};  // E 3 kPa, nu 0.45
    const double strain = 1e-4;
    // Rollers: the bottom (z = 0) slides in its plane, held at the origin
    // (x, y) and at node 1 (y) against rigid motion; the top moves in z.
    dg::sim::BoundaryConditions conditions;
    for (int n : {0, 1, 2, 3}) conditions.fixed_dofs.push_back(3 * n + 2);
    conditions.fixed_dofs.insert(conditions.fixed_dofs.end(), {0, 1, 3 * 1 + 1});
    for (int n : {4, 5, 6, 7}) conditions.prescribed_dofs.push_back(3 * n + 2);

    dg::sim::SolverOptions options;
    options.damping_per_s = 400;  // near-critical for the slowest mode
    const dg::sim::StabilityReport stability =
        dg::sim::EstimateStability(mesh, material, conditions.fixed_dofs);
    options.dt_s = 0.4 * stability.dt_critical_s;
    options.threads = 1;
    dg::sim::TledSolver<double> solver(std::make_shared<const dg::sim::TledModel<double>>(mesh, material),
                                       conditions, options);
    const std::vector<double> targets_m(conditions.prescribed_dofs.size(), strain * kSide_m);
    solver.Advance(static_cast<int>(0.05 / options.dt_s), targets_m);  // pull over 50 ms
    solver.Advance(static_cast<int>(0.15 / options.dt_s), targets_m);  // then rest
    double reaction_n = 0;
    for (int dof : conditions.prescribed_dofs) reaction_n += solver.reaction_forces()[dof];
    std::printf("nominal_stress_pa %.9g\n", reaction_n / (kSide_m * kSide_m));
    std::printf("hooke_stress_pa %.9g\n", material.youngs_modulus_pa * strain);
    return 0;
  } catch (const dg::Error& e) {
    std::fprintf(stderr, "consumer: %s\n", e.what());
    return 1;
  }
}
