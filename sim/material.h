#pragma once

#include <string>

namespace dg::sim {

// Compressible neo-Hookean solid in the form TLED codes use (paper section 2.3):
//   S = mu J^(-2/3) (I - tr(C)/3 C^-1) + kappa J (J - 1) C^-1,
// from the strain energy W = mu/2 (J^(-2/3) tr C - 3) + kappa/2 (J - 1)^2.
// Its small-strain limit is linear elasticity with the given E and nu.
// Defaults are the paper's (Pratt et al. 2010, section 2.3).
struct Material {
  double youngs_modulus_pa = 3.0e3;
  double poissons_ratio = 0.45;
  double density_kg_m3 = 1.0e3;

  // Empty when valid; otherwise what is wrong and how to fix it.
  std::string Validate() const;

  double shear_modulus_pa() const { return youngs_modulus_pa / (2.0 * (1.0 + poissons_ratio)); }
  double bulk_modulus_pa() const { return youngs_modulus_pa / (3.0 * (1.0 - 2.0 * poissons_ratio)); }
  double lame_lambda_pa() const { return bulk_modulus_pa() - 2.0 / 3.0 * shear_modulus_pa(); }
  // Speed of pressure waves, sqrt((lambda + 2 mu) / rho): sets the stable time step.
  double dilatational_wave_speed_m_s() const;
};

}  // namespace dg::sim
