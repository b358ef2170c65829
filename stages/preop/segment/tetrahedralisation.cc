#include "stages/preop/segment/tetrahedralisation.h"

#include <algorithm>
#include <array>
#include <map>
#include <cmath>
#include <iterator>
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

// Throws unless the surface bounds one solid ball: Gmsh's reparametrisation
// of the patches fails on anything else, with a message no user can act on.
void RequireClosedManifold(const io::SurfaceMesh& surface, const std::string& name, const std::string& where) {
  const SurfaceTopology topology = CheckSurfaceTopology(surface);
  if (topology.IsClosedManifoldSphere()) return;
  throw Error(fmt::format("{} ({} triangles) is not the boundary of one solid ball: {}", name,
                          surface.num_triangles(), topology.Describe()),
              where,
              "if it was extracted from a mask, extract it again with more smoothing (preop --smoothing-voxels) "
              "or another --triangles; a surface file must be one closed, consistently oriented surface without "
              "tunnels (repair it in MeshLab or 3D Slicer)");
}

// The mesh's elements against the quality bound.
struct Quality {
  double min_radius_ratio = HUGE_VAL;
  double mean_radius_ratio = 0;
  int worst_element = -1;
  int under_bound = 0;
};

Quality MeasureQuality(const sim::TetMesh& mesh, double bound) {
  Quality quality;
  for (int e = 0; e < mesh.num_tets(); ++e) {
    const double q = io::RadiusRatio(mesh, e);
    if (q < quality.min_radius_ratio) quality.min_radius_ratio = q, quality.worst_element = e;
    quality.mean_radius_ratio += q / mesh.num_tets();
    quality.under_bound += q < bound;
  }
  return quality;
}

// Removes the elements under the bound that have two or three faces on the
// boundary, while that leaves the boundary a closed 2-manifold: Gmsh leaves
// such slivers flat along the surface's sharp curves (a label cut by the
// grid's first slice has a rim), and its optimiser cannot move their nodes,
// which all lie on the surface. Each one removed takes its volume, a few
// cubic micrometres, off the solid. Returns how many were removed.
int PeelBoundarySlivers(double bound, sim::TetMesh* mesh) {
  using Face = std::array<int, 3>;
  auto face_of = [&](int e, int skip) {
    Face face;
    for (int c = 0, n = 0; c < 4; ++c) if (c != skip) face[n++] = mesh->tets(c, e);
    std::sort(face.begin(), face.end());
    return face;
  };
  int removed = 0;
  for (bool changed = true; changed;) {
    changed = false;
    std::map<Face, int> uses;
    std::map<std::pair<int, int>, int> boundary_edge_uses;
    for (int e = 0; e < mesh->num_tets(); ++e) for (int c = 0; c < 4; ++c) ++uses[face_of(e, c)];
    for (const auto& [face, count] : uses) {
      if (count != 1) continue;
      for (int c = 0; c < 3; ++c) ++boundary_edge_uses[std::minmax(face[c], face[(c + 1) % 3])];
    }
    std::vector<bool> on_boundary(mesh->num_nodes(), false);
    for (const auto& [edge, count] : boundary_edge_uses) on_boundary[edge.first] = on_boundary[edge.second] = true;
    for (int e = 0; e < mesh->num_tets() && !changed; ++e) {
      if (io::RadiusRatio(*mesh, e) >= bound) continue;
      std::vector<int> inner;  // the corners opposite the faces inside the solid
      for (int c = 0; c < 4; ++c) if (uses[face_of(e, c)] == 2) inner.push_back(c);
      bool keeps_manifold = false;
      if (inner.size() == 2) {
        // The inner faces share the edge of the two corners opposite the
        // boundary faces; it must not lie on the boundary already.
        std::vector<int> edge;
        for (int c = 0; c < 4; ++c) if (c != inner[0] && c != inner[1]) edge.push_back(mesh->tets(c, e));
        keeps_manifold = !boundary_edge_uses.count(std::minmax(edge[0], edge[1]));
      } else if (inner.size() == 1) {
        // The corner where three boundary faces meet leaves the solid with the element.
        keeps_manifold = true;
      }
      if (!keeps_manifold) continue;
      mesh->tets.col(e) = mesh->tets.col(mesh->num_tets() - 1);
      mesh->tets.conservativeResize(Eigen::NoChange, mesh->num_tets() - 1);
      ++removed, changed = true;
    }
  }
  if (removed > 0) sim::RemoveUnusedNodes(mesh);
  return removed;
}

Eigen::Vector3d Centroid(const sim::TetMesh& mesh, int e) {
  return 0.25 * (mesh.X_m.col(mesh.tets(0, e)) + mesh.X_m.col(mesh.tets(1, e)) + mesh.X_m.col(mesh.tets(2, e)) +
                 mesh.X_m.col(mesh.tets(3, e)));
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
  if (!(min_radius_ratio >= 0 && min_radius_ratio < 1)) {
    return fmt::format("min_radius_ratio must lie in [0, 1), got {:g}", min_radius_ratio);
  }
  return "";
}

sim::TetMesh Tetrahedralise(const io::SurfaceMesh& surface, const VoxelMask& mount,
                            const TetrahedralisationOptions& options, TetrahedralisationReport* report) {
  if (std::string problem = options.Validate(); !problem.empty()) {
    throw Error("invalid tetrahedralisation options: " + problem, kWhere, "correct the option");
  }
  const std::string where = fmt::format("tetrahedralisation of {}", options.surface_name);
  RequireClosedManifold(surface, options.surface_name, where);
  const double enclosed_m3 = SixEnclosedVolume(surface) / 6;
  if (!(enclosed_m3 > 0)) {
    throw Error(fmt::format("{} encloses a volume of {:g} m^3", options.surface_name, enclosed_m3), where,
                "orient the triangles counter-clockwise seen from outside (ExtractSurface does)");
  }

  io::gmsh_module::MeshRequest request;
  request.solid.kind = io::gmsh_module::Solid::Kind::kClosedSurface;
  // Gmsh meshes the surface about its first vertex: floating point is not
  // translation invariant, and one scan read from DICOM and from NIfTI lies
  // on grids whose origins differ in the last decimal DICOM's text keeps
  // (5e-8 mm), which was enough to change the mesh. About a point of the
  // surface itself the two are the same numbers, and so is the mesh.
  const Eigen::Vector3d about_m = surface.vertices_m.col(0);
  const Eigen::Matrix3Xd local_m = surface.vertices_m.colwise() - about_m;
  request.solid.vertices_m.assign(local_m.data(), local_m.data() + local_m.size());
  request.solid.triangles.assign(surface.triangles.data(), surface.triangles.data() + surface.triangles.size());
  request.solid.feature_angle_rad = options.feature_angle_deg * std::numbers::pi / 180;
  request.volume_m3 = enclosed_m3;
  request.target_tets = options.target_tets;
  request.max_passes = kMaxMeshingPasses;
  const std::string gmsh_fix =
      fmt::format("extract the surface again with more smoothing (preop --smoothing-voxels) or another "
                  "--triangles, or ask for another --tets (now {}); Gmsh needs one closed surface that does not "
                  "cut itself",
                  options.target_tets);
  const auto mesh_in_gmsh = [&] {
    try {
      io::GmshMeshing meshing = io::MeshInGmsh(request, where, gmsh_fix);
      meshing.mesh.X_m.colwise() += about_m;
      return meshing;
    } catch (const Error& e) {
      throw UnmeshableSurface(e.problem(), e.where(), e.fix());
    }
  };
  io::GmshMeshing meshing = mesh_in_gmsh();
  TetrahedralisationReport r;
  r.min_radius_ratio_meshed = MeasureQuality(meshing.mesh, options.min_radius_ratio).min_radius_ratio;
  r.slivers_removed = PeelBoundarySlivers(options.min_radius_ratio, &meshing.mesh);
  Quality quality = MeasureQuality(meshing.mesh, options.min_radius_ratio);
  for (const Remeshing& remeshing : kRemeshings) {
    if (quality.min_radius_ratio >= options.min_radius_ratio) break;
    // Gmsh's optimiser works on the elements under its threshold: aim above
    // the bound so that the elements near it improve too.
    request.optimisation_rounds = remeshing.optimisation_rounds;
    request.optimisation_threshold = std::min(1.0, 2 * options.min_radius_ratio);
    request.target_tets = std::max(1, static_cast<int>(std::lround(remeshing.target_scale * options.target_tets)));
    io::GmshMeshing remeshed = mesh_in_gmsh();
    const int peeled = PeelBoundarySlivers(options.min_radius_ratio, &remeshed.mesh);
    const Quality remeshed_quality = MeasureQuality(remeshed.mesh, options.min_radius_ratio);
    Logger("stages").info("{}: worst radius ratio {:.3f} with {} more rounds of Gmsh's optimiser, {:g} x the target "
                          "(was {:.3f})",
                          where, remeshed_quality.min_radius_ratio, remeshing.optimisation_rounds,
                          remeshing.target_scale, quality.min_radius_ratio);
    if (remeshed_quality.min_radius_ratio > quality.min_radius_ratio) {
      meshing = std::move(remeshed), quality = remeshed_quality;
      r.optimisation_rounds = remeshing.optimisation_rounds, r.target_scale = remeshing.target_scale;
      r.slivers_removed = peeled;
    }
  }
  sim::TetMesh& mesh = meshing.mesh;
  if (quality.min_radius_ratio < options.min_radius_ratio) {
    const Eigen::Vector3d worst_mm = 1e3 * Centroid(mesh, quality.worst_element);
    throw UnmeshableSurface(fmt::format("the mesh of {} has {} of its {} tetrahedra under the radius ratio {:g}, the worst "
                            "{:.3f} at ({:.1f}, {:.1f}, {:.1f}) mm, after {} remeshings with up to {} more rounds of Gmsh's "
                            "optimiser",
                            options.surface_name, quality.under_bound, mesh.num_tets(), options.min_radius_ratio,
                            quality.min_radius_ratio, worst_mm.x(), worst_mm.y(), worst_mm.z(),
                            std::size(kRemeshings), kRemeshings[1].optimisation_rounds),
                where,
                fmt::format("ask for another --tets (now {}) or --triangles, or smooth the surface more: slivers "
                            "sit where the surface has detail finer than the elements",
                            options.target_tets));
  }
  r.element_size_m = meshing.element_size_m;
  r.passes = meshing.passes;
  AddNodeSets(mount, options.base_distance_m, &mesh);

  r.nodes = mesh.num_nodes();
  r.tets = mesh.num_tets();
  r.surface_nodes = static_cast<int>(mesh.node_sets["surface"].size());
  r.base_nodes = static_cast<int>(mesh.node_sets["base"].size());
  r.min_radius_ratio = quality.min_radius_ratio;
  r.mean_radius_ratio = quality.mean_radius_ratio;
  for (int e = 0; e < mesh.num_tets(); ++e) r.volume_m3 += sim::SixSignedVolume(mesh, e) / 6;
  Logger("stages").info("tetrahedralised {} ({} triangles): {} nodes ({} on the free surface, {} on the mount), {} "
                        "tets (target {}, h = {:.3g} mm, {} passes), radius ratio min {:.3f} (meshed {:.3f}, {} "
                        "boundary slivers removed, {} more optimiser rounds) mean {:.3f}",
                        options.surface_name, surface.num_triangles(), r.nodes, r.surface_nodes, r.base_nodes, r.tets,
                        options.target_tets, 1e3 * r.element_size_m, r.passes, r.min_radius_ratio,
                        r.min_radius_ratio_meshed, r.slivers_removed, r.optimisation_rounds, r.mean_radius_ratio);
  if (std::abs(static_cast<double>(r.tets) / options.target_tets - 1) > kTetCountTolerance) {
    Logger("stages").warn("{}: got {} tets, more than {:.0f}% off the target {}", where, r.tets,
                          100 * kTetCountTolerance, options.target_tets);
  }
  if (report) *report = r;
  return std::move(mesh);
}

}  // namespace dg::stages::preop
