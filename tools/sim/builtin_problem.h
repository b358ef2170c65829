#pragma once

namespace dg::tools {

// The built-in example of `dynaguide sim`: a 5 cm cube of the paper's
// material on a fixed base, its top face held laterally and pressed down 1 cm
// by a quintic ramp over 0.5 s, then held; 1 s simulated. Printed by
// `dynaguide sim --print-example` as a template for users' own problems.
inline constexpr char kBuiltinProblem[] = R"(# dynaguide sim problem: every key, with its unit in its name.
mesh:
  generate: box              # box | ellipsoid (or 'file: mesh.msh' with 'units: mm')
  size_m: [0.05, 0.05, 0.05] # box edges, or ellipsoid semi-axes
  tets: 20000                # target tetrahedron count (--tets overrides)
material:                    # compressible neo-Hookean (Pratt et al. 2010)
  youngs_modulus_pa: 3000
  poissons_ratio: 0.45
  density_kg_m3: 1000
solver:
  dt_s: 2.0e-4
  damping_per_s: 75          # alpha of the mass-proportional damping
  precision: float           # float | double
  time_step_policy: refuse   # refuse | substep | unchecked
  stability_safety: 0        # allowed fraction of the critical time step (0: by nu, 0.9 to 0.65)
gravity_m_s2: [0, 0, 0]
duration_s: 1.0
output_every_s: 0.01
fixed:                       # each: set | plane | box, and axes
  - set: zmin
    axes: xyz
prescribed:
  - name: top
    set: zmax                # or plane: {point_m: [0, 0, 0.05], normal: [0, 0, 1], tolerance_m: 1.0e-6}
    axes: xyz                # held laterally (x, y = 0), moved in z
    displacement_m: [0, 0, -0.01]
    ramp: quintic            # quintic | linear
    ramp_s: 0.5
)";

}  // namespace dg::tools
