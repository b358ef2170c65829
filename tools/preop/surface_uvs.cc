#include "tools/preop/surface_uvs.h"

namespace dg::tools::preop {

Eigen::Matrix2Xd PlanarUvs(const io::SurfaceMesh& surface) {
  const Eigen::Vector2d low = surface.vertices_m.topRows<2>().rowwise().minCoeff();
  const Eigen::Vector2d extent = (surface.vertices_m.topRows<2>().rowwise().maxCoeff() - low).cwiseMax(1e-12);
  return (surface.vertices_m.topRows<2>().colwise() - low).array().colwise() / extent.array();
}

}  // namespace dg::tools::preop
