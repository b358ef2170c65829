#include "stages/preop/segment/tetrahedralisation.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <map>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>
#include <fmt/format.h>
#include <gmsh.h>

#include "io/gmsh_mesher.h"
#include "io/gmsh_session.h"
#include "sim/error.h"
#include "sim/log.h"
#include "stages/preop/segment/surface_extraction.h"

namespace dg::stages::preop {
namespace {

constexpr const char* kWhere = "tetrahedralisation of the segmented surface";

// Gmsh's Delaunay mesher with optimisation fills a volume V with about
// 5 V / h^3 tetrahedra at characteristic length h (io/gmsh_mesher.cc); only
// the first pass relies on it.
constexpr double kTetsPerCubicLength = 5.0;
constexpr double kTetCountGoodEnough = 0.05;

// Throws unless every edge is shared by exactly two triangles.
void RequireClosed(const io::SurfaceMesh& surface) {
  std::map<std::pair<int, int>, int> uses;
  for (int t = 0; t < surface.num_triangles(); ++t) {
    for (int c = 0; c < 3; ++c) {
      const int a = surface.triangles(c, t), b = surface.triangles((c + 1) % 3, t);
      ++uses[std::minmax(a, b)];
    }
  }
  for (const auto& [edge, count] : uses) {
    if (count != 2) {
      throw Error(fmt::format("the surface is not closed: edge ({}, {}) belongs to {} triangles", edge.first,
                              edge.second, count),
                  kWhere, "extract the surface from a mask with ExtractSurface, which gives a closed surface");
    }
  }
}

// Whether point x_S lies within distance_m of a voxel of the mask, each voxel
// the box of its spacing around its centre.
class MaskProximity {
 public:
  MaskProximity(const VoxelMask& mask, double distance_m)
      : mask_(mask), to_index_(mask.direction.inverse()), distance_m_(distance_m) {
    reach_ = (distance_m / mask.spacing_m.array()).ceil().cast<int>() + 1;
  }

  bool Near(const Eigen::Vector3d& x_S) const {
    const Eigen::Vector3d q = (to_index_ * (x_S - mask_.origin_m)).cwiseQuotient(mask_.spacing_m);
    const Eigen::Vector3i centre = q.array().round().cast<int>();
    const Eigen::Vector3i lo = (centre - reach_).cwiseMax(0);
    const Eigen::Vector3i hi = (centre + reach_).cwiseMin(mask_.size - Eigen::Vector3i::Ones());
    for (int k = lo.z(); k <= hi.z(); ++k) {
      for (int j = lo.y(); j <= hi.y(); ++j) {
        for (int i = lo.x(); i <= hi.x(); ++i) {
          if (!mask_.inside[mask_.Index(i, j, k)]) continue;
          const Eigen::Vector3d outside_box =
              ((q - Eigen::Vector3d(i, j, k)).cwiseAbs().array() - 0.5).cwiseMax(0.0).matrix();
          if (outside_box.cwiseProduct(mask_.spacing_m).norm() <= distance_m_) return true;
        }
      }
    }
    return false;
  }

 private:
  const VoxelMask& mask_;
  Eigen::Matrix3d to_index_;
  double distance_m_;
  Eigen::Vector3i reach_;
};

// Loads the surface as one discrete surface, splits it into patches Gmsh can
// reparametrise, and bounds a volume by them.
void BuildVolume(const io::SurfaceMesh& surface, double feature_angle_rad) {
  gmsh::model::add("organ");
  gmsh::model::addDiscreteEntity(2, 1);
  std::vector<std::size_t> node_tags(surface.num_vertices());
  std::vector<double> coords(3 * node_tags.size());
  for (int v = 0; v < surface.num_vertices(); ++v) {
    node_tags[v] = v + 1;
    for (int d = 0; d < 3; ++d) coords[3 * v + d] = surface.vertices_m(d, v);
  }
  gmsh::model::mesh::addNodes(2, 1, node_tags, coords);
  std::vector<std::size_t> triangle_tags(surface.num_triangles()), triangle_nodes;
  for (int t = 0; t < surface.num_triangles(); ++t) {
    triangle_tags[t] = t + 1;
    for (int c = 0; c < 3; ++c) triangle_nodes.push_back(surface.triangles(c, t) + 1);
  }
  gmsh::model::mesh::addElementsByType(1, 2, triangle_tags, triangle_nodes);
  gmsh::model::mesh::classifySurfaces(feature_angle_rad, /*boundary=*/true, /*forReparametrization=*/true,
                                      /*curveAngle=*/std::numbers::pi);
  gmsh::model::mesh::createGeometry();
  gmsh::vectorpair patches;
  gmsh::model::getEntities(patches, 2);
  std::vector<int> patch_tags;
  for (const auto& [dim, tag] : patches) patch_tags.push_back(tag);
  gmsh::model::geo::addVolume({gmsh::model::geo::addSurfaceLoop(patch_tags)});
  gmsh::model::geo::synchronize();
}

sim::TetMesh ReadTetMesh(io::GmshSession* session) {
  std::vector<std::size_t> node_tags, tet_tags, tet_nodes;
  std::vector<double> coords, parametric;
  session->Run("reading the mesh", [&] {
    gmsh::model::mesh::getNodes(node_tags, coords, parametric, -1, -1, /*includeBoundary=*/false,
                                /*returnParametricCoord=*/false);
    gmsh::model::mesh::getElementsByType(4, tet_tags, tet_nodes);
  });
  sim::TetMesh mesh;
  mesh.source = kWhere;
  std::map<std::size_t, int> node_index;  // Gmsh's tags need not be contiguous
  mesh.X_m.resize(3, static_cast<Eigen::Index>(node_tags.size()));
  for (std::size_t i = 0; i < node_tags.size(); ++i) {
    node_index[node_tags[i]] = static_cast<int>(i);
    mesh.X_m.col(i) << coords[3 * i], coords[3 * i + 1], coords[3 * i + 2];
  }
  mesh.tets.resize(4, static_cast<Eigen::Index>(tet_tags.size()));
  for (std::size_t e = 0; e < tet_tags.size(); ++e) {
    for (int c = 0; c < 4; ++c) mesh.tets(c, e) = node_index.at(tet_nodes[4 * e + c]);
  }
  return mesh;
}

std::vector<int> SortedUnique(std::vector<int> ids) {
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

// "base": the boundary triangles touching the mount; "surface": the others;
// each set the nodes of its triangles, so both are patches of the boundary
// (io::WriteMsh writes them as physical surfaces).
void AddNodeSets(const VoxelMask& mount, double base_distance_m, sim::TetMesh* mesh) {
  const MaskProximity near_mount(mount, base_distance_m);
  std::vector<bool> touches(mesh->num_nodes(), false);
  for (int a : sim::BoundaryNodes(*mesh)) touches[a] = near_mount.Near(mesh->X_m.col(a));
  const Eigen::Matrix3Xi faces = sim::BoundaryFaces(*mesh);
  std::vector<int> base, free;
  for (int f = 0; f < faces.cols(); ++f) {
    const bool on_mount = touches[faces(0, f)] && touches[faces(1, f)] && touches[faces(2, f)];
    for (int c = 0; c < 3; ++c) (on_mount ? base : free).push_back(faces(c, f));
  }
  mesh->node_sets["base"] = SortedUnique(std::move(base));
  mesh->node_sets["surface"] = SortedUnique(std::move(free));
  std::vector<int> all(mesh->num_nodes());
  for (int a = 0; a < mesh->num_nodes(); ++a) all[a] = a;
  mesh->node_sets["body"] = all;
  std::vector<int> elements(mesh->num_tets());
  for (int e = 0; e < mesh->num_tets(); ++e) elements[e] = e;
  mesh->element_sets["body"] = std::move(elements);
}

}  // namespace

std::string TetrahedralisationOptions::Validate() const {
  if (target_tets <= 0) return fmt::format("target_tets must be positive, got {}", target_tets);
  if (!(feature_angle_deg > 0 && feature_angle_deg < 180)) {
    return fmt::format("feature_angle_deg must lie in (0, 180), got {:g}", feature_angle_deg);
  }
  if (!(base_distance_m >= 0 && std::isfinite(base_distance_m))) {
    return fmt::format("base_distance_m must be finite and >= 0, got {:g}", base_distance_m);
  }
  return "";
}

sim::TetMesh Tetrahedralise(const io::SurfaceMesh& surface, const VoxelMask& mount,
                            const TetrahedralisationOptions& options, TetrahedralisationReport* report) {
  if (std::string problem = options.Validate(); !problem.empty()) {
    throw Error("invalid tetrahedralisation options: " + problem, kWhere, "correct the option");
  }
  RequireClosed(surface);
  const double enclosed_m3 = SixEnclosedVolume(surface) / 6;
  if (!(enclosed_m3 > 0)) {
    throw Error(fmt::format("the surface encloses a volume of {:g} m^3", enclosed_m3), kWhere,
                "orient the triangles counter-clockwise seen from outside (ExtractSurface does)");
  }

  sim::TetMesh mesh;
  TetrahedralisationReport r;
  {
    io::GmshSession session(kWhere,
                            "check that the surface is one closed, non-self-intersecting shell; try another target count",
                            io::GmshSession::SurfaceAlgorithm::kFrontalDelaunay);
    session.Run("building the volume from the surface",
                [&] { BuildVolume(surface, options.feature_angle_deg * std::numbers::pi / 180); });

    // Count ~ h^-3, so each pass rescales h by the cube root of the count's error.
    auto generate = [&](double h) {
      ++r.passes;
      std::vector<std::size_t> tags, nodes;
      session.Run("meshing", [&] {
        gmsh::model::mesh::clear();
        gmsh::option::setNumber("Mesh.MeshSizeMin", h);
        gmsh::option::setNumber("Mesh.MeshSizeMax", h);
        gmsh::model::mesh::generate(3);
        gmsh::model::mesh::getElementsByType(4, tags, nodes);
      });
      return static_cast<double>(tags.size());
    };
    double h = std::cbrt(kTetsPerCubicLength * enclosed_m3 / options.target_tets);
    double best_h = h, best_error = HUGE_VAL, meshed_h = 0;
    for (int pass = 0; pass < kMaxMeshingPasses; ++pass) {
      const double count = generate(h);
      meshed_h = h;
      const double error = std::abs(count / options.target_tets - 1.0);
      if (error < best_error) best_error = error, best_h = h;
      if (error <= kTetCountGoodEnough || count == 0) break;
      h *= std::cbrt(count / options.target_tets);
    }
    if (meshed_h != best_h) generate(best_h);
    r.element_size_m = best_h;
    mesh = ReadTetMesh(&session);
  }
  sim::RemoveUnusedNodes(&mesh);
  sim::OrientElements(&mesh);
  AddNodeSets(mount, options.base_distance_m, &mesh);

  r.nodes = mesh.num_nodes();
  r.tets = mesh.num_tets();
  r.surface_nodes = static_cast<int>(mesh.node_sets["surface"].size());
  r.base_nodes = static_cast<int>(mesh.node_sets["base"].size());
  r.min_radius_ratio = HUGE_VAL;
  for (int e = 0; e < mesh.num_tets(); ++e) {
    const double q = io::RadiusRatio(mesh, e);
    r.min_radius_ratio = std::min(r.min_radius_ratio, q);
    r.mean_radius_ratio += q / mesh.num_tets();
    r.volume_m3 += sim::SixSignedVolume(mesh, e) / 6;
  }
  Logger("stages").info("tetrahedralised the surface ({} triangles): {} nodes ({} on the free surface, {} on the "
                        "mount), {} tets (target {}, h = {:.3g} mm, {} passes), radius ratio min {:.3f} mean {:.3f}",
                        surface.num_triangles(), r.nodes, r.surface_nodes, r.base_nodes, r.tets, options.target_tets,
                        1e3 * r.element_size_m, r.passes, r.min_radius_ratio, r.mean_radius_ratio);
  if (std::abs(static_cast<double>(r.tets) / options.target_tets - 1) > kTetCountTolerance) {
    Logger("stages").warn("{}: got {} tets, more than {:.0f}% off the target {}", kWhere, r.tets,
                          100 * kTetCountTolerance, options.target_tets);
  }
  if (report) *report = r;
  return mesh;
}

}  // namespace dg::stages::preop
