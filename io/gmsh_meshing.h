#pragma once

#include <string>

#include "io/gmsh_module/interface.h"
#include "sim/tet_mesh.h"

namespace dg::io {

// Gmsh's SDK, seen from the program: calls into the Gmsh module
// (io/gmsh_module/), which is loaded on the first call and stays loaded. The
// module is looked for in this order:
//   1. the file the environment variable DG_GMSH_MODULE names, if it is set;
//   2. kGmshModuleFile in the installed tree beside the running program
//      (<prefix>/lib/.../dynaguide/, docs/install.md);
//   3. the build tree's module, for programs and tests run from the build.
inline constexpr char kGmshModuleFile[] = "dynaguide-gmsh.so";

// A solid meshed by Gmsh.
struct GmshMeshing {
  // In metres, positively oriented (sim::OrientElements has run), without
  // unused nodes, in Gmsh's node order; each physical group becomes a node set
  // of its nodes, and a physical volume also an element set.
  sim::TetMesh mesh;
  double element_size_m = 0;  // Gmsh's characteristic length on the pass kept
  int passes = 0;             // meshings run to approach the target count
  double count_error = 0;     // |tets / target - 1| on the pass kept
  int unused_nodes_dropped = 0;
};

// @throws dg::Error naming `where` and `fix` when Gmsh fails, or naming the
//   places searched when the module cannot be loaded.
GmshMeshing MeshInGmsh(const gmsh_module::MeshRequest& request, const std::string& where, const std::string& fix);
void WriteMshInGmsh(const gmsh_module::MshFile& file, const std::string& where, const std::string& fix);

}  // namespace dg::io
