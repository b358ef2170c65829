#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace dg::sim {

// A linear (4-node) tetrahedral mesh in its reference configuration, in metres.
// Built by a reader or generator, then checked once by OrientElements(); the
// solver takes it read-only. Node and element ids are 0-based column indices.
struct TetMesh {
  Eigen::Matrix3Xd X_m;                        // reference node positions, one column per node
  Eigen::Matrix<int, 4, Eigen::Dynamic> tets;  // node ids of each element
  // Named sets (from the file's physical groups, or selected geometrically):
  // sorted, unique ids. A physical surface or volume yields a node set of all
  // its nodes; a physical volume also yields an element set.
  std::map<std::string, std::vector<int>> node_sets;
  std::map<std::string, std::vector<int>> element_sets;
  std::string source;  // the file or generator it came from, for error messages
  // Where each element came from, for messages only: the element's tag in
  // the file and the file's line that defines it (0 where not known). Empty
  // for a generated mesh. Kept beside the mesh so that internal renumbering
  // (nodes; element order inside the model) never reaches a user's message.
  std::vector<long long> element_tags;
  std::vector<int> element_lines;

  int num_nodes() const { return static_cast<int>(X_m.cols()); }
  int num_tets() const { return static_cast<int>(tets.cols()); }
};

// Six times the signed volume of element e: positive when nodes 1, 2, 3 are
// counter-clockwise seen from outside, i.e. (X1-X0) x (X2-X0) . (X3-X0) > 0.
double SixSignedVolume(const TetMesh& mesh, int element);

// Element e as a user finds it: "mesh.msh:42, element 17" with the file's tag
// and line when the mesh was read from a file, else "element 5" (its 0-based
// id in a generated mesh). Error paths only.
std::string ElementName(const TetMesh& mesh, int element);

enum class Orientation { kReorient, kReject };

// Checks node ids are in range and every element has a volume above a relative
// tolerance; flips negatively oriented elements (swapping nodes 2 and 3) or, with
// kReject, rejects them. Returns the number of flipped elements.
// @throws dg::Error naming the element, its nodes and the mesh source.
int OrientElements(TetMesh* mesh, Orientation policy = Orientation::kReorient);

// Triangles that belong to exactly one element, wound so their normal points
// out of the mesh. One column per face.
Eigen::Matrix3Xi BoundaryFaces(const TetMesh& mesh);

// Sorted ids of the nodes on the boundary.
std::vector<int> BoundaryNodes(const TetMesh& mesh);

// Sorted ids of nodes within tolerance_m of the plane through point_m with the
// given normal (need not be unit length).
std::vector<int> NodesNearPlane(const TetMesh& mesh, const Eigen::Vector3d& point_m,
                                const Eigen::Vector3d& normal, double tolerance_m);

// Sorted ids of nodes inside the axis-aligned box [lo_m, hi_m] grown by tolerance_m.
std::vector<int> NodesInBox(const TetMesh& mesh, const Eigen::Vector3d& lo_m,
                            const Eigen::Vector3d& hi_m, double tolerance_m);

// Node -> (element, corner) incidence in compressed rows: the incidences of
// node a are entries [offsets[a], offsets[a+1]), in increasing element order.
struct NodeIncidence {
  std::vector<int> offsets;   // size num_nodes + 1
  std::vector<int> elements;  // element id of each incidence
  std::vector<int> corners;   // corner (0..3) of the node in that element
};
NodeIncidence BuildNodeIncidence(const TetMesh& mesh);

// Axis-aligned bounding box of the reference nodes: columns are min and max.
Eigen::Matrix<double, 3, 2> BoundingBox(const TetMesh& mesh);

}  // namespace dg::sim

namespace dg::sim {

// Drops nodes that no element uses (a mass-less node would make the explicit
// update divide by zero) and renumbers the rest in their old order; node sets
// are remapped and lose the dropped ids. Returns how many were dropped.
int RemoveUnusedNodes(TetMesh* mesh);

}  // namespace dg::sim

namespace dg::sim {

// Renumbers nodes along a Morton (Z-order) curve through their reference
// positions, so that nodes close in space are close in memory: the TLED
// kernel's gathers then hit cache lines already loaded. Node sets are remapped;
// elements keep their order. Returns new_id[old_id].
std::vector<int> RenumberNodesForLocality(TetMesh* mesh);

}  // namespace dg::sim
