#include "tests/sim/box_mesh.h"

#include <random>

namespace dg::sim::testing {

TetMesh MakeBoxMesh(int nx, int ny, int nz, const Eigen::Vector3d& size_m, double jitter, unsigned seed) {
  TetMesh mesh;
  mesh.source = "test box mesh";
  auto id = [&](int i, int j, int k) { return i + (nx + 1) * (j + (ny + 1) * k); };
  mesh.X_m.resize(3, (nx + 1) * (ny + 1) * (nz + 1));
  const Eigen::Vector3d cell(size_m.x() / nx, size_m.y() / ny, size_m.z() / nz);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(-jitter, jitter);
  for (int k = 0; k <= nz; ++k) {
    for (int j = 0; j <= ny; ++j) {
      for (int i = 0; i <= nx; ++i) {
        Eigen::Vector3d x(i * cell.x(), j * cell.y(), k * cell.z());
        const bool interior = i > 0 && i < nx && j > 0 && j < ny && k > 0 && k < nz;
        if (interior && jitter > 0) x += cell.cwiseProduct(Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)));
        mesh.X_m.col(id(i, j, k)) = x;
      }
    }
  }
  // Six tetrahedra sharing the diagonal from corner 0 to corner 7 of each cube.
  constexpr int kTets[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7}, {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};
  mesh.tets.resize(4, 6 * nx * ny * nz);
  int e = 0;
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        for (const auto& tet : kTets) {
          for (int c = 0; c < 4; ++c) {
            const int corner = tet[c];
            mesh.tets(c, e) = id(i + (corner & 1), j + ((corner >> 1) & 1), k + ((corner >> 2) & 1));
          }
          ++e;
        }
      }
    }
  }
  OrientElements(&mesh);
  for (int axis = 0; axis < 3; ++axis) {
    const char* names[3][2] = {{"xmin", "xmax"}, {"ymin", "ymax"}, {"zmin", "zmax"}};
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    normal[axis] = 1;
    mesh.node_sets[names[axis][0]] = NodesNearPlane(mesh, Eigen::Vector3d::Zero(), normal, 1e-9 * size_m[axis]);
    mesh.node_sets[names[axis][1]] = NodesNearPlane(mesh, size_m, normal, 1e-9 * size_m[axis]);
  }
  return mesh;
}

}  // namespace dg::sim::testing
