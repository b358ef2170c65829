#include "io/gmsh_module/solids.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <gmsh.h>

namespace dg::io::gmsh_module {

void AddPhysicalGroup(int dim, const std::vector<int>& tags, const std::string& name) {
  gmsh::model::setPhysicalName(dim, gmsh::model::addPhysicalGroup(dim, tags), name);
}

namespace {

// Names the box face that an axis-aligned planar surface lies on.
std::string BoxFaceName(int surface_tag, const std::array<double, 3>& size_m) {
  double lo[3], hi[3];
  gmsh::model::getBoundingBox(2, surface_tag, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
  int axis = 0;  // the axis along which the face is thinnest, relative to the box
  for (int i = 1; i < 3; ++i) {
    if ((hi[i] - lo[i]) / size_m[i] < (hi[axis] - lo[axis]) / size_m[axis]) axis = i;
  }
  const bool at_max = 0.5 * (lo[axis] + hi[axis]) > 0.5 * size_m[axis];
  return std::string(1, "xyz"[axis]) + (at_max ? "max" : "min");
}

void AddBox(const std::array<double, 3>& size) {
  const int volume = gmsh::model::occ::addBox(0, 0, 0, size[0], size[1], size[2]);
  gmsh::model::occ::synchronize();
  gmsh::vectorpair surfaces;
  gmsh::model::getEntities(surfaces, 2);
  for (const auto& [dim, tag] : surfaces) AddPhysicalGroup(2, {tag}, BoxFaceName(tag, size));
  AddPhysicalGroup(3, {volume}, "body");
}

void AddEllipsoid(const std::array<double, 3>& axes) {
  const int volume = gmsh::model::occ::addSphere(0, 0, 0, 1.0);
  gmsh::model::occ::dilate({{3, volume}}, 0, 0, 0, axes[0], axes[1], axes[2]);
  gmsh::model::occ::synchronize();
  gmsh::vectorpair surfaces;
  gmsh::model::getEntities(surfaces, 2);
  std::vector<int> surface_tags;
  for (const auto& [dim, tag] : surfaces) surface_tags.push_back(tag);
  AddPhysicalGroup(2, surface_tags, "surface");
  AddPhysicalGroup(3, {volume}, "body");
}

void AddTruncatedEllipsoid(const std::array<double, 3>& axes, double h) {
  const int ellipsoid = gmsh::model::occ::addSphere(0, 0, h, 1.0);
  gmsh::model::occ::dilate({{3, ellipsoid}}, 0, 0, h, axes[0], axes[1], axes[2]);
  const double reach = 2 * std::max({axes[0], axes[1], axes[2]}) + std::abs(h);
  const int half_space = gmsh::model::occ::addBox(-reach, -reach, 0, 2 * reach, 2 * reach, 2 * reach);
  gmsh::vectorpair kept;
  std::vector<gmsh::vectorpair> map;
  gmsh::model::occ::intersect({{3, ellipsoid}}, {{3, half_space}}, kept, map);
  gmsh::model::occ::synchronize();
  gmsh::vectorpair surfaces;
  gmsh::model::getBoundary(kept, surfaces, /*combined=*/true, /*oriented=*/false);
  std::vector<int> curved, base;
  for (const auto& [dim, tag] : surfaces) {
    double x0, y0, z0, x1, y1, z1;
    gmsh::model::getBoundingBox(dim, tag, x0, y0, z0, x1, y1, z1);
    (z1 < 1e-3 * reach ? base : curved).push_back(tag);  // OCC pads bounding boxes loosely
  }
  AddPhysicalGroup(2, curved, "surface");
  AddPhysicalGroup(2, base, "base");
  AddPhysicalGroup(3, {kept.at(0).second}, "body");
}

// Loads the surface as one discrete surface, splits it into patches Gmsh can
// reparametrise, and bounds a volume by them.
void AddClosedSurface(const Solid& solid) {
  gmsh::model::add("organ");
  gmsh::model::addDiscreteEntity(2, 1);
  const std::size_t num_vertices = solid.vertices_m.size() / 3, num_triangles = solid.triangles.size() / 3;
  std::vector<std::size_t> node_tags(num_vertices);
  for (std::size_t v = 0; v < num_vertices; ++v) node_tags[v] = v + 1;
  gmsh::model::mesh::addNodes(2, 1, node_tags, solid.vertices_m);
  std::vector<std::size_t> triangle_tags(num_triangles), triangle_nodes(solid.triangles.size());
  for (std::size_t t = 0; t < num_triangles; ++t) triangle_tags[t] = t + 1;
  for (std::size_t i = 0; i < solid.triangles.size(); ++i) triangle_nodes[i] = solid.triangles[i] + 1;
  gmsh::model::mesh::addElementsByType(1, 2, triangle_tags, triangle_nodes);
  gmsh::model::mesh::classifySurfaces(solid.feature_angle_rad, /*boundary=*/true, /*forReparametrization=*/true,
                                      /*curveAngle=*/std::numbers::pi);
  gmsh::model::mesh::createGeometry();
  gmsh::vectorpair patches;
  gmsh::model::getEntities(patches, 2);
  std::vector<int> patch_tags;
  for (const auto& [dim, tag] : patches) patch_tags.push_back(tag);
  gmsh::model::geo::addVolume({gmsh::model::geo::addSurfaceLoop(patch_tags)});
  gmsh::model::geo::synchronize();
}

}  // namespace

void AddSolid(const Solid& solid) {
  switch (solid.kind) {
    case Solid::Kind::kBox:
      return AddBox(solid.lengths_m);
    case Solid::Kind::kEllipsoid:
      return AddEllipsoid(solid.lengths_m);
    case Solid::Kind::kTruncatedEllipsoid:
      return AddTruncatedEllipsoid(solid.lengths_m, solid.centre_height_m);
    case Solid::Kind::kClosedSurface:
      return AddClosedSurface(solid);
  }
}

}  // namespace dg::io::gmsh_module
