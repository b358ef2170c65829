#include "sim/tet_mesh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <unordered_map>

#include <Eigen/Geometry>

#include "sim/error.h"

namespace dg::sim {
namespace {

// The element's name, and for a generated mesh its nodes (a file's line shows them already).
std::string ElementWhere(const TetMesh& mesh, int e) {
  if (static_cast<int>(mesh.element_tags.size()) == mesh.num_tets()) return ElementName(mesh, e);
  return mesh.source + ", " + ElementName(mesh, e) + " (nodes " + std::to_string(mesh.tets(0, e)) + " " + std::to_string(mesh.tets(1, e)) +
         " " + std::to_string(mesh.tets(2, e)) + " " + std::to_string(mesh.tets(3, e)) + ")";
}

// The four faces of a tetrahedron, each wound outward for a positive element.
constexpr std::array<std::array<int, 3>, 4> kFaces = {{{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}}};

}  // namespace

double SixSignedVolume(const TetMesh& mesh, int e) {
  const Eigen::Vector3d x0 = mesh.X_m.col(mesh.tets(0, e));
  const Eigen::Vector3d a = mesh.X_m.col(mesh.tets(1, e)) - x0;
  const Eigen::Vector3d b = mesh.X_m.col(mesh.tets(2, e)) - x0;
  const Eigen::Vector3d c = mesh.X_m.col(mesh.tets(3, e)) - x0;
  return a.cross(b).dot(c);
}

std::string ElementName(const TetMesh& mesh, int e) {
  if (static_cast<int>(mesh.element_tags.size()) != mesh.num_tets()) {
    return "element " + std::to_string(e);
  }
  const bool has_line = static_cast<int>(mesh.element_lines.size()) == mesh.num_tets() && mesh.element_lines[e] > 0;
  // Appended piece by piece: GCC 12 warns (-Wrestrict, falsely) on a literal
  // prepended to a temporary string here.
  std::string name = mesh.source;
  if (has_line) name.append(":").append(std::to_string(mesh.element_lines[e]));
  return name.append(", element ").append(std::to_string(mesh.element_tags[e]));
}

int OrientElements(TetMesh* mesh, Orientation policy) {
  const int n = mesh->num_nodes();
  if (n == 0 || mesh->num_tets() == 0) {
    throw Error("mesh has no tetrahedra", mesh->source,
                "give a volume mesh with 4-node tetrahedra (in Gmsh: Mesh 3D)");
  }
  if (!mesh->X_m.allFinite()) {
    throw Error("mesh has non-finite node coordinates", mesh->source, "repair the mesh file");
  }
  // Degeneracy is judged against the mesh's own scale, so units do not matter.
  const Eigen::Matrix<double, 3, 2> box = BoundingBox(*mesh);
  const double extent = (box.col(1) - box.col(0)).maxCoeff();
  const double mean_six_volume = 6.0 * std::pow(extent, 3) / mesh->num_tets();
  const double degenerate_six_volume = 1e-9 * mean_six_volume;

  int flipped = 0;
  for (int e = 0; e < mesh->num_tets(); ++e) {
    for (int corner = 0; corner < 4; ++corner) {
      const int node = mesh->tets(corner, e);
      if (node < 0 || node >= n) {
        throw Error("element refers to node " + std::to_string(node) + " but the mesh has " +
                        std::to_string(n) + " nodes",
                    ElementWhere(*mesh, e), "repair the mesh's element list");
      }
    }
    const double six_volume = SixSignedVolume(*mesh, e);
    if (std::abs(six_volume) <= degenerate_six_volume) {
      throw Error("degenerate element (volume " + std::to_string(six_volume / 6.0) + " m^3)",
                  ElementWhere(*mesh, e), "remesh; Gmsh's Mesh.Optimize removes slivers");
    }
    if (six_volume < 0) {
      if (policy == Orientation::kReject) {
        throw Error("inverted (negatively oriented) element", ElementWhere(*mesh, e),
                    "swap two of its nodes, or load the mesh with reorientation on");
      }
      std::swap(mesh->tets(2, e), mesh->tets(3, e));
      ++flipped;
    }
  }
  return flipped;
}

Eigen::Matrix3Xi BoundaryFaces(const TetMesh& mesh) {
  // A face is interior when two elements share it; key by its sorted node ids.
  struct Key {
    std::array<int, 3> sorted;
    bool operator==(const Key& other) const { return sorted == other.sorted; }
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      return (size_t(k.sorted[0]) * 73856093u) ^ (size_t(k.sorted[1]) * 19349663u) ^
             (size_t(k.sorted[2]) * 83492791u);
    }
  };
  std::unordered_map<Key, std::pair<int, int>, KeyHash> count_and_first;  // face -> (count, e*4+f)
  count_and_first.reserve(static_cast<size_t>(mesh.num_tets()) * 4);
  for (int e = 0; e < mesh.num_tets(); ++e) {
    for (int f = 0; f < 4; ++f) {
      Key key{{mesh.tets(kFaces[f][0], e), mesh.tets(kFaces[f][1], e), mesh.tets(kFaces[f][2], e)}};
      std::sort(key.sorted.begin(), key.sorted.end());
      auto [it, inserted] = count_and_first.try_emplace(key, 0, e * 4 + f);
      ++it->second.first;
    }
  }
  std::vector<int> boundary;  // e*4+f, in element order for determinism
  for (const auto& [key, value] : count_and_first) {
    if (value.first == 1) boundary.push_back(value.second);
  }
  std::sort(boundary.begin(), boundary.end());
  Eigen::Matrix3Xi faces(3, static_cast<Eigen::Index>(boundary.size()));
  for (size_t i = 0; i < boundary.size(); ++i) {
    const int e = boundary[i] / 4, f = boundary[i] % 4;
    for (int k = 0; k < 3; ++k) faces(k, static_cast<Eigen::Index>(i)) = mesh.tets(kFaces[f][k], e);
  }
  return faces;
}

std::vector<int> BoundaryNodes(const TetMesh& mesh) {
  const Eigen::Matrix3Xi faces = BoundaryFaces(mesh);
  std::vector<int> nodes(faces.data(), faces.data() + faces.size());
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  return nodes;
}

std::vector<int> NodesNearPlane(const TetMesh& mesh, const Eigen::Vector3d& point_m,
                                const Eigen::Vector3d& normal, double tolerance_m) {
  if (!(normal.norm() > 0)) {
    throw Error("plane normal is zero", "node selection", "give a non-zero normal vector");
  }
  const Eigen::Vector3d unit = normal.normalized();
  std::vector<int> nodes;
  for (int a = 0; a < mesh.num_nodes(); ++a) {
    if (std::abs(unit.dot(mesh.X_m.col(a) - point_m)) <= tolerance_m) nodes.push_back(a);
  }
  return nodes;
}

std::vector<int> NodesInBox(const TetMesh& mesh, const Eigen::Vector3d& lo_m,
                            const Eigen::Vector3d& hi_m, double tolerance_m) {
  std::vector<int> nodes;
  for (int a = 0; a < mesh.num_nodes(); ++a) {
    const Eigen::Vector3d x = mesh.X_m.col(a);
    if ((x.array() >= lo_m.array() - tolerance_m).all() &&
        (x.array() <= hi_m.array() + tolerance_m).all()) {
      nodes.push_back(a);
    }
  }
  return nodes;
}

NodeIncidence BuildNodeIncidence(const TetMesh& mesh) {
  NodeIncidence incidence;
  incidence.offsets.assign(mesh.num_nodes() + 1, 0);
  for (int e = 0; e < mesh.num_tets(); ++e) {
    for (int c = 0; c < 4; ++c) ++incidence.offsets[mesh.tets(c, e) + 1];
  }
  for (int a = 0; a < mesh.num_nodes(); ++a) incidence.offsets[a + 1] += incidence.offsets[a];
  incidence.elements.resize(incidence.offsets.back());
  incidence.corners.resize(incidence.offsets.back());
  std::vector<int> next(incidence.offsets.begin(), incidence.offsets.end() - 1);
  for (int e = 0; e < mesh.num_tets(); ++e) {
    for (int c = 0; c < 4; ++c) {
      const int slot = next[mesh.tets(c, e)]++;
      incidence.elements[slot] = e;
      incidence.corners[slot] = c;
    }
  }
  return incidence;
}

Eigen::Matrix<double, 3, 2> BoundingBox(const TetMesh& mesh) {
  Eigen::Matrix<double, 3, 2> box;
  box.col(0) = mesh.X_m.rowwise().minCoeff();
  box.col(1) = mesh.X_m.rowwise().maxCoeff();
  return box;
}

}  // namespace dg::sim

namespace dg::sim {

int RemoveUnusedNodes(TetMesh* mesh) {
  std::vector<int> new_id(mesh->num_nodes(), -1);
  for (int e = 0; e < mesh->num_tets(); ++e) {
    for (int c = 0; c < 4; ++c) new_id[mesh->tets(c, e)] = 0;
  }
  int kept = 0;
  for (int& id : new_id) {
    if (id == 0) id = kept++;
  }
  const int dropped = mesh->num_nodes() - kept;
  if (dropped == 0) return 0;
  Eigen::Matrix3Xd X(3, kept);
  for (int a = 0; a < mesh->num_nodes(); ++a) {
    if (new_id[a] >= 0) X.col(new_id[a]) = mesh->X_m.col(a);
  }
  mesh->X_m = std::move(X);
  for (int e = 0; e < mesh->num_tets(); ++e) {
    for (int c = 0; c < 4; ++c) mesh->tets(c, e) = new_id[mesh->tets(c, e)];
  }
  for (auto& [name, nodes] : mesh->node_sets) {
    std::vector<int> remapped;
    for (int a : nodes) {
      if (new_id[a] >= 0) remapped.push_back(new_id[a]);
    }
    nodes = std::move(remapped);
  }
  return dropped;
}

}  // namespace dg::sim

namespace dg::sim {
namespace {

// Spreads the low 10 bits of v so that two zero bits follow each.
uint32_t SpreadBits(uint32_t v) {
  v &= 0x3ff;
  v = (v | (v << 16)) & 0x030000ff;
  v = (v | (v << 8)) & 0x0300f00f;
  v = (v | (v << 4)) & 0x030c30c3;
  v = (v | (v << 2)) & 0x09249249;
  return v;
}

}  // namespace

std::vector<int> RenumberNodesForLocality(TetMesh* mesh) {
  const Eigen::Matrix<double, 3, 2> box = BoundingBox(*mesh);
  const Eigen::Vector3d extent = (box.col(1) - box.col(0)).cwiseMax(1e-300);
  std::vector<std::pair<uint32_t, int>> keys(mesh->num_nodes());
  for (int a = 0; a < mesh->num_nodes(); ++a) {
    const Eigen::Vector3d unit = (mesh->X_m.col(a) - box.col(0)).cwiseQuotient(extent);
    uint32_t code = 0;
    for (int i = 0; i < 3; ++i) code |= SpreadBits(static_cast<uint32_t>(std::min(unit[i], 1.0) * 1023.0)) << i;
    keys[a] = {code, a};
  }
  std::sort(keys.begin(), keys.end());
  std::vector<int> new_id(mesh->num_nodes());
  Eigen::Matrix3Xd X(3, mesh->num_nodes());
  for (int k = 0; k < mesh->num_nodes(); ++k) {
    new_id[keys[k].second] = k;
    X.col(k) = mesh->X_m.col(keys[k].second);
  }
  mesh->X_m = std::move(X);
  for (int e = 0; e < mesh->num_tets(); ++e) {
    for (int c = 0; c < 4; ++c) mesh->tets(c, e) = new_id[mesh->tets(c, e)];
  }
  for (auto& [name, nodes] : mesh->node_sets) {
    for (int& a : nodes) a = new_id[a];
    std::sort(nodes.begin(), nodes.end());
  }
  return new_id;
}

}  // namespace dg::sim
