#pragma once

// What the program and its Gmsh module exchange. Gmsh's SDK and the 41 MB of
// libraries under it (OpenCASCADE, its linear algebra) live in the module,
// which the program loads the first time it meshes or writes a .msh file, so
// a process that only steps a model never maps them (docs/install.md, "The
// Gmsh module"). Plain data only: no Eigen and no dg type crosses, and no
// exception either: each entry point returns why it failed.

#include <array>
#include <cstddef>
#include <string>
#include <vector>

namespace dg::io::gmsh_module {

// Raised whenever a type below or an entry point's signature changes, so a
// program never calls a module built from other sources.
inline constexpr int kInterfaceVersion = 2;

// A solid for Gmsh to mesh, in metres.
struct Solid {
  enum class Kind {
    kBox,                 // min corner at the origin, size `lengths_m`
    kEllipsoid,           // centred at the origin, semi-axes `lengths_m`
    kTruncatedEllipsoid,  // semi-axes `lengths_m`, centre `centre_height_m` above z = 0, cut by it
    kClosedSurface        // the volume `vertices_m` and `triangles` enclose
  };
  Kind kind = Kind::kBox;
  std::array<double, 3> lengths_m{};
  double centre_height_m = 0;
  std::vector<double> vertices_m;  // x, y, z of each vertex
  std::vector<int> triangles;      // three 0-based vertex ids each, counter-clockwise seen from outside
  // Patches of a closed surface bend by less than this between neighbouring
  // triangles; sharper edges become curves.
  double feature_angle_rad = 0;
};

// Meshes `solid`, approaching `target_tets`: the characteristic length is
// estimated from volume_m3 / target_tets, then corrected from the counts of
// up to max_passes meshings; the pass nearest the target is kept. With
// optimisation_rounds > 0 the pass kept is then optimised that many times
// more, each round Gmsh's tetrahedral optimiser (edge and face swaps, on the
// elements of quality under optimisation_threshold) then its node relocation.
struct MeshRequest {
  Solid solid;
  double volume_m3 = 0;
  int target_tets = 0;
  int max_passes = 0;
  int optimisation_rounds = 0;
  double optimisation_threshold = 0.3;  // Gmsh's Mesh.OptimizeThreshold, on its quality "gamma" in (0, 1]
};

// A named physical group of the mesh: for dimension 3, the tetrahedra of its
// volumes and their nodes; for 2, the nodes of its surfaces.
struct PhysicalGroup {
  int dim = 0;
  std::string name;
  std::vector<std::size_t> node_tags;
  std::vector<std::size_t> tet_tags;
};

// The mesh as Gmsh holds it: tags are positive but need not be contiguous.
struct Tetrahedra {
  std::vector<std::size_t> node_tags;
  std::vector<double> coords;  // x, y, z of each node, in node_tags' order
  std::vector<std::size_t> tet_tags;
  std::vector<std::size_t> tet_nodes;  // four node tags per tetrahedron
  std::vector<PhysicalGroup> groups;
  double element_size_m = 0;  // characteristic length of the pass kept
  int passes = 0;             // meshings run
  double count_error = 0;     // |count / target - 1| of the pass kept
};

// A .msh file for Gmsh to write: node a has tag a + 1.
struct MshFile {
  struct Volume {  // a discrete volume, and the physical volumes it belongs to
    std::vector<std::size_t> tet_tags, tet_nodes;
    std::vector<std::string> groups;
  };
  struct Surface {  // a discrete surface that is a physical surface of its own
    std::string group;
    std::vector<std::size_t> triangle_tags, triangle_nodes;
  };
  std::string path;
  double format = 4.1;         // 2.2 or 4.1
  bool save_all = false;       // write elements in no physical group (a mesh without groups)
  std::vector<double> coords;  // x, y, z of each node
  std::vector<Volume> volumes;
  std::vector<Surface> surfaces;
};

// The module's entry points. Each returns "" on success, else the step that
// failed and Gmsh's reason. Gmsh is one process-wide state: calls from several
// threads run one after another.
struct Functions {
  int interface_version;
  std::string (*mesh)(const MeshRequest& request, Tetrahedra* out);
  std::string (*write_msh)(const MshFile& file);
};

// The one symbol the module exports (C linkage, so dlsym finds it by name).
inline constexpr char kEntryPoint[] = "dg_gmsh_module_functions";
using EntryPoint = const Functions* (*)();

}  // namespace dg::io::gmsh_module
