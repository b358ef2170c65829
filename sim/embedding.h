#pragma once

#include <string>

#include <Eigen/Core>

#include "sim/tet_mesh.h"

namespace dg::sim {

// Points (vertices of overlay meshes, internal landmarks) carried by the
// tetrahedra of a reference mesh: each point is located once in the element
// that contains it, x = sum_k w_k x_{n_k} over that element's four nodes, and
// the weights (barycentric coordinates, computed in double) stay fixed while
// the nodes move. A point outside the mesh (a surface vertex beyond the
// polyhedral boundary's chords, say) is tied to the element owning the
// nearest boundary face and extrapolated by the same affine map; such points
// are counted. Under any affine motion of the nodes every point moves by that
// motion exactly, inside or outside.
//
// Location uses uniform grids (of element bounding boxes; of boundary faces
// for outside points), not a scan over elements. Immutable after
// construction; Rebuild() is const and may run on several frames at once.
class Embedding {
 public:
  // @throws dg::Error if the mesh has no elements or a point is not finite.
  Embedding(const TetMesh& mesh, const Eigen::Matrix3Xd& points_m);

  // positions(:, p) = sum_k weights(k, p) nodes_m(:, node_ids(k, p)), in
  // parallel over points. Works for nodes in any frame (scan or camera).
  // @pre nodes_m has the reference mesh's node count; *positions is resized.
  void Rebuild(const Eigen::Matrix3Xd& nodes_m, Eigen::Matrix3Xd* positions) const;
  Eigen::Matrix3Xd Rebuild(const Eigen::Matrix3Xd& nodes_m) const;

  int num_points() const { return static_cast<int>(weights_.cols()); }
  int num_nodes() const { return num_nodes_; }
  // How many points lie outside every element, and the farthest of them from the mesh.
  int num_outside() const { return num_outside_; }
  double max_outside_distance_m() const { return max_outside_distance_m_; }
  const Eigen::Matrix<int, 4, Eigen::Dynamic>& node_ids() const { return node_ids_; }
  const Eigen::Matrix4Xd& weights() const { return weights_; }
  const Eigen::VectorXi& elements() const { return elements_; }

  // One line for logs and command summaries.
  std::string Describe() const;

 private:
  int num_nodes_ = 0;
  Eigen::Matrix<int, 4, Eigen::Dynamic> node_ids_;
  Eigen::Matrix4Xd weights_;
  Eigen::VectorXi elements_;
  int num_outside_ = 0;
  double max_outside_distance_m_ = 0;
};

}  // namespace dg::sim
