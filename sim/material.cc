#include "sim/material.h"

#include <cmath>

namespace dg::sim {

std::string Material::Validate() const {
  if (!std::isfinite(youngs_modulus_pa) || youngs_modulus_pa <= 0) {
    return "Young's modulus must be positive and finite (got " + std::to_string(youngs_modulus_pa) +
           " Pa); soft tissue is about 1e3 to 1e5 Pa";
  }
  if (!std::isfinite(poissons_ratio) || poissons_ratio <= -1.0 || poissons_ratio >= 0.5) {
    return "Poisson's ratio must lie in (-1, 0.5) (got " + std::to_string(poissons_ratio) +
           "); near-incompressible tissue is 0.45 to 0.499";
  }
  if (!std::isfinite(density_kg_m3) || density_kg_m3 <= 0) {
    return "density must be positive and finite (got " + std::to_string(density_kg_m3) +
           " kg/m^3); soft tissue is about 1000 kg/m^3";
  }
  return {};
}

double Material::dilatational_wave_speed_m_s() const {
  return std::sqrt((lame_lambda_pa() + 2.0 * shear_modulus_pa()) / density_kg_m3);
}

}  // namespace dg::sim
