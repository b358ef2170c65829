// The Gmsh module's entry points (interface.h): meshing a solid to a target
// element count, and writing a .msh file.

#include <cmath>
#include <exception>
#include <map>
#include <string>
#include <vector>

#include <gmsh.h>

#include "io/gmsh_module/interface.h"
#include "io/gmsh_module/session.h"
#include "io/gmsh_module/solids.h"

namespace dg::io::gmsh_module {
namespace {

// Gmsh's Delaunay mesher with optimisation fills a volume V with about
// 5 V / h^3 tetrahedra at characteristic length h (measured on boxes and
// ellipsoids; regular tetrahedra of edge h would give 8.5). Only the first
// pass relies on it: later passes correct h from the count obtained.
constexpr double kTetsPerCubicLength = 5.0;

// A pass this close to the target ends the search early.
constexpr double kTetCountGoodEnough = 0.05;

// Runs `body`, turning anything it throws into the message an entry point returns.
template <typename Body>
std::string Failure(Body&& body) {
  try {
    body();
    return "";
  } catch (const std::exception& e) {
    return e.what();
  } catch (...) {
    return "an unknown exception in the Gmsh module";
  }
}

void ReadMesh(Session* session, Tetrahedra* out) {
  session->Run("reading the mesh", [&] {
    std::vector<double> parametric;
    gmsh::model::mesh::getNodes(out->node_tags, out->coords, parametric, -1, -1, /*includeBoundary=*/false,
                                /*returnParametricCoord=*/false);
    gmsh::model::mesh::getElementsByType(4, out->tet_tags, out->tet_nodes);
  });
  session->Run("reading the physical groups", [&] {
    gmsh::vectorpair groups;
    gmsh::model::getPhysicalGroups(groups);
    for (const auto& [dim, tag] : groups) {
      PhysicalGroup& group = out->groups.emplace_back();
      group.dim = dim;
      gmsh::model::getPhysicalName(dim, tag, group.name);
      std::vector<double> unused;
      gmsh::model::mesh::getNodesForPhysicalGroup(dim, tag, group.node_tags, unused);
      if (dim != 3) continue;
      std::vector<int> entities;
      gmsh::model::getEntitiesForPhysicalGroup(dim, tag, entities);
      for (int entity : entities) {
        std::vector<std::size_t> tags, nodes;
        gmsh::model::mesh::getElementsByType(4, tags, nodes, entity);
        group.tet_tags.insert(group.tet_tags.end(), tags.begin(), tags.end());
      }
    }
  });
}

std::string Mesh(const MeshRequest& request, Tetrahedra* out) {
  return Failure([&] {
    *out = {};
    // Delaunay surfaces on CAD solids: Frontal-Delaunay ones left 3D Delaunay
    // with boundary slivers its optimiser could not remove (radius ratio down
    // to 2e-4). On the reparametrised patches of a discrete surface it is the
    // other way round: Delaunay left a sliver of 0.02, Frontal-Delaunay gave 0.2.
    Session session(request.solid.kind == Solid::Kind::kClosedSurface ? Session::SurfaceAlgorithm::kFrontalDelaunay
                                                                       : Session::SurfaceAlgorithm::kDelaunay);
    session.Run("building the geometry", [&] { AddSolid(request.solid); });

    auto count_at = [&](double h) {
      ++out->passes;
      std::vector<std::size_t> tags, nodes;
      session.Run("meshing", [&] {
        gmsh::model::mesh::clear();
        gmsh::option::setNumber("Mesh.MeshSizeMin", h);
        gmsh::option::setNumber("Mesh.MeshSizeMax", h);
        Session::Mesh([] { gmsh::model::mesh::generate(3); });
        gmsh::model::mesh::getElementsByType(4, tags, nodes);
      });
      return static_cast<double>(tags.size());
    };
    // Count ~ h^-3, so each pass rescales h by the cube root of the count's error.
    double h = std::cbrt(kTetsPerCubicLength * request.volume_m3 / request.target_tets);
    double best_h = h, best_error = HUGE_VAL, meshed_h = 0;
    for (int pass = 0; pass < request.max_passes; ++pass) {
      const double count = count_at(h);
      meshed_h = h;
      const double error = std::abs(count / request.target_tets - 1.0);
      if (error < best_error) best_error = error, best_h = h;
      if (error <= kTetCountGoodEnough || count == 0) break;
      h *= std::cbrt(count / request.target_tets);
    }
    if (meshed_h != best_h) count_at(best_h);
    if (request.optimisation_rounds > 0) {
      session.Run("optimising the tetrahedra", [&] {
        gmsh::option::setNumber("Mesh.OptimizeThreshold", request.optimisation_threshold);
        for (int round = 0; round < request.optimisation_rounds; ++round) {
          Session::Mesh([] {
            gmsh::model::mesh::optimize("", /*force=*/false, /*niter=*/1);
            gmsh::model::mesh::optimize("Relocate3D", /*force=*/false, /*niter=*/1);
          });
        }
      });
    }
    out->element_size_m = best_h;
    out->count_error = best_error;
    ReadMesh(&session, out);
  });
}

std::string WriteMsh(const MshFile& file) {
  return Failure([&] {
    Session session;
    session.Run("writing the mesh", [&] {
      gmsh::model::add("dynaguide");
      // Every node goes to the first volume; Gmsh needs no finer classification to write.
      std::vector<std::size_t> node_tags(file.coords.size() / 3);
      for (std::size_t a = 0; a < node_tags.size(); ++a) node_tags[a] = a + 1;
      std::map<std::string, std::vector<int>> volumes_of_group;
      int volume_tag = 0;
      for (const MshFile::Volume& volume : file.volumes) {
        gmsh::model::addDiscreteEntity(3, ++volume_tag);
        if (volume_tag == 1) gmsh::model::mesh::addNodes(3, 1, node_tags, file.coords);
        gmsh::model::mesh::addElementsByType(volume_tag, 4, volume.tet_tags, volume.tet_nodes);
        for (const std::string& name : volume.groups) volumes_of_group[name].push_back(volume_tag);
      }
      for (const auto& [name, tags] : volumes_of_group) AddPhysicalGroup(3, tags, name);
      int surface_tag = 0;
      for (const MshFile::Surface& surface : file.surfaces) {
        gmsh::model::addDiscreteEntity(2, ++surface_tag);
        gmsh::model::mesh::addElementsByType(surface_tag, 2, surface.triangle_tags, surface.triangle_nodes);
        AddPhysicalGroup(2, {surface_tag}, surface.group);
      }
      gmsh::option::setNumber("Mesh.MshFileVersion", file.format);
      gmsh::option::setNumber("Mesh.Binary", 0);
      gmsh::option::setNumber("Mesh.SaveAll", file.save_all ? 1 : 0);
      gmsh::write(file.path);
    });
  });
}

constexpr Functions kFunctions{kInterfaceVersion, &Mesh, &WriteMsh};

}  // namespace
}  // namespace dg::io::gmsh_module

extern "C" __attribute__((visibility("default"))) const dg::io::gmsh_module::Functions* dg_gmsh_module_functions() {
  return &dg::io::gmsh_module::kFunctions;
}
