#include "sim/element_measures.h"

#include <cmath>

#include <catch2/catch.hpp>

#include "tests/sim/box_mesh.h"

namespace dg::sim {

// Isochoric uniaxial stretch F = diag(l, l^-1/2, l^-1/2): J = 1 and the Cauchy
// stress is mu (B - tr(B)/3 I), whose von Mises value is mu (l^2 - 1/l).
TEST_CASE("element measures: von Mises stress of isochoric stretch", "[sim][unit]") {
  const TetMesh mesh = testing::MakeBoxMesh(3, 3, 3, {0.01, 0.01, 0.01}, 0.3);
  const Material material{};
  const double l = 1.3;
  const Eigen::Vector3d stretch(l, 1 / std::sqrt(l), 1 / std::sqrt(l));
  const Eigen::Matrix3Xd u = (stretch.asDiagonal() * mesh.X_m - mesh.X_m).eval();
  const ElementMeasures measures = ComputeElementMeasures(mesh, material, u);
  for (int e = 0; e < mesh.num_tets(); ++e) {
    REQUIRE(measures.volume_ratio[e] == Approx(1.0).epsilon(1e-12));
    REQUIRE(measures.von_mises_pa[e] == Approx(material.shear_modulus_pa() * (l * l - 1 / l)).epsilon(1e-10));
  }
}

}  // namespace dg::sim
