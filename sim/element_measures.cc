#include "sim/element_measures.h"

#include <cmath>

#include <Eigen/LU>

namespace dg::sim {

template <typename T>
Eigen::Matrix3d DeformationGradient(const TetMesh& mesh, int e, const T* u) {
  Eigen::Matrix3d reference, current;
  const int n0 = mesh.tets(0, e);
  for (int c = 0; c < 3; ++c) {
    const int nc = mesh.tets(c + 1, e);
    reference.col(c) = mesh.X_m.col(nc) - mesh.X_m.col(n0);
    for (int i = 0; i < 3; ++i) {
      current(i, c) = reference(i, c) + double(u[3 * nc + i]) - double(u[3 * n0 + i]);
    }
  }
  return current * reference.inverse();
}

ElementMeasures ComputeElementMeasures(const TetMesh& mesh, const Material& material,
                                       const Eigen::Matrix3Xd& u_m) {
  const double mu = material.shear_modulus_pa(), kappa = material.bulk_modulus_pa();
  ElementMeasures measures;
  measures.volume_ratio.resize(mesh.num_tets());
  measures.von_mises_pa.resize(mesh.num_tets());
  for (int e = 0; e < mesh.num_tets(); ++e) {
    const Eigen::Matrix3d F = DeformationGradient(mesh, e, u_m.data());
    const double J = F.determinant();
    const Eigen::Matrix3d C = F.transpose() * F;
    const Eigen::Matrix3d C_inv = C.inverse();
    const Eigen::Matrix3d S = mu * std::pow(J, -2.0 / 3.0) * (Eigen::Matrix3d::Identity() - C.trace() / 3 * C_inv) +
                              kappa * J * (J - 1) * C_inv;
    const Eigen::Matrix3d sigma = F * S * F.transpose() / J;
    const Eigen::Matrix3d deviator = sigma - sigma.trace() / 3 * Eigen::Matrix3d::Identity();
    measures.volume_ratio[e] = J;
    measures.von_mises_pa[e] = std::sqrt(1.5 * deviator.squaredNorm());
  }
  return measures;
}

template Eigen::Matrix3d DeformationGradient<float>(const TetMesh&, int, const float*);
template Eigen::Matrix3d DeformationGradient<double>(const TetMesh&, int, const double*);

}  // namespace dg::sim
