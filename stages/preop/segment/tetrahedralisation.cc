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

#include "io/gmsh_mesher.h"
#include "io/gmsh_meshing.h"
#include "sim/error.h"
#include "sim/log.h"
#include "stages/preop/segment/surface_extraction.h"

namespace dg::stages::preop {
namespace {

constexpr const char* kWhere = "tetrahedralisation of the segmented surface";

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

  io::gmsh_module::MeshRequest request;
  request.solid.kind = io::gmsh_module::Solid::Kind::kClosedSurface;
  request.solid.vertices_m.assign(surface.vertices_m.data(), surface.vertices_m.data() + surface.vertices_m.size());
  request.solid.triangles.assign(surface.triangles.data(), surface.triangles.data() + surface.triangles.size());
  request.solid.feature_angle_rad = options.feature_angle_deg * std::numbers::pi / 180;
  request.volume_m3 = enclosed_m3;
  request.target_tets = options.target_tets;
  request.max_passes = kMaxMeshingPasses;
  io::GmshMeshing meshing = io::MeshInGmsh(
      request, kWhere, "check that the surface is one closed, non-self-intersecting shell; try another target count");
  sim::TetMesh& mesh = meshing.mesh;
  TetrahedralisationReport r;
  r.element_size_m = meshing.element_size_m;
  r.passes = meshing.passes;
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
  return std::move(mesh);
}

}  // namespace dg::stages::preop
