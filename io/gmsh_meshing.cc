#include "io/gmsh_meshing.h"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "io/running_program.h"
#include "sim/error.h"
#include "sim/log.h"

namespace dg::io {
namespace {

constexpr const char* kModuleFix =
    "rebuild (cmake --build) or reinstall dynaguide, or set DG_GMSH_MODULE to the module's path";

// Where the module may be, in the order tried (gmsh_meshing.h).
std::vector<std::string> ModuleCandidates() {
  if (const char* named = std::getenv("DG_GMSH_MODULE")) {
    // dlopen("") would give the program itself, not a module.
    if (*named == '\0') {
      throw Error("DG_GMSH_MODULE is set but empty", "loading the Gmsh module",
                  "unset DG_GMSH_MODULE, or set it to the path of dynaguide-gmsh.so");
    }
    return {named};
  }
  std::vector<std::string> candidates;
  // Without the program's own folder the build tree's module can still serve.
  try {
    candidates.push_back((RunningProgramFolder() / DG_GMSH_MODULE_FROM_BINDIR / kGmshModuleFile).lexically_normal());
  } catch (const Error& error) {
    Logger("io").warn("not looking for the installed Gmsh module beside the program: {}", error.what());
  }
  candidates.push_back(DG_GMSH_MODULE_IN_BUILD_TREE);
  return candidates;
}

const gmsh_module::Functions* LoadModule() {
  std::string tried;
  for (const std::string& path : ModuleCandidates()) {
    // RTLD_LOCAL: Gmsh's libraries serve the module and nothing else.
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      tried += fmt::format("\n  {}", dlerror());  // names the path and why it failed
      continue;
    }
    const auto entry = reinterpret_cast<gmsh_module::EntryPoint>(dlsym(handle, gmsh_module::kEntryPoint));
    const gmsh_module::Functions* functions = entry ? entry() : nullptr;
    if (!functions || functions->interface_version != gmsh_module::kInterfaceVersion) {
      throw Error(fmt::format("{} is not this program's Gmsh module: it has {} (this program needs interface "
                              "version {})",
                              path, functions ? fmt::format("interface version {}", functions->interface_version)
                                              : fmt::format("no {}", gmsh_module::kEntryPoint),
                              gmsh_module::kInterfaceVersion),
                  "loading the Gmsh module", kModuleFix);
    }
    Logger("io").debug("loaded the Gmsh module {}", path);
    return functions;  // stays loaded: Gmsh's state lives for the process
  }
  throw Error("cannot load the Gmsh module, which meshing and writing .msh files need; tried:" + tried,
              "loading the Gmsh module", kModuleFix);
}

const gmsh_module::Functions& Module() {
  // A failed load throws out of the initialiser, so the next call tries again.
  static const gmsh_module::Functions* const functions = LoadModule();
  return *functions;
}

std::vector<int> SortedUnique(std::vector<int> ids) {
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

sim::TetMesh ToTetMesh(const gmsh_module::Tetrahedra& gmsh, const std::string& source) {
  sim::TetMesh mesh;
  mesh.source = source;
  std::map<std::size_t, int> node_index, tet_index;  // Gmsh's tags need not be contiguous
  mesh.X_m.resize(3, static_cast<Eigen::Index>(gmsh.node_tags.size()));
  for (std::size_t i = 0; i < gmsh.node_tags.size(); ++i) {
    node_index[gmsh.node_tags[i]] = static_cast<int>(i);
    mesh.X_m.col(i) << gmsh.coords[3 * i], gmsh.coords[3 * i + 1], gmsh.coords[3 * i + 2];
  }
  mesh.tets.resize(4, static_cast<Eigen::Index>(gmsh.tet_tags.size()));
  for (std::size_t e = 0; e < gmsh.tet_tags.size(); ++e) {
    tet_index[gmsh.tet_tags[e]] = static_cast<int>(e);
    for (int c = 0; c < 4; ++c) mesh.tets(c, e) = node_index.at(gmsh.tet_nodes[4 * e + c]);
  }
  for (const gmsh_module::PhysicalGroup& group : gmsh.groups) {
    std::vector<int>& nodes = mesh.node_sets[group.name];
    for (std::size_t t : group.node_tags) nodes.push_back(node_index.at(t));
    nodes = SortedUnique(std::move(nodes));
    if (group.dim != 3) continue;
    std::vector<int>& elements = mesh.element_sets[group.name];
    for (std::size_t t : group.tet_tags) elements.push_back(tet_index.at(t));
    elements = SortedUnique(std::move(elements));
  }
  return mesh;
}

}  // namespace

GmshMeshing MeshInGmsh(const gmsh_module::MeshRequest& request, const std::string& where, const std::string& fix) {
  gmsh_module::Tetrahedra tetrahedra;
  if (std::string failure = Module().mesh(request, &tetrahedra); !failure.empty()) throw Error(failure, where, fix);
  GmshMeshing result;
  result.mesh = ToTetMesh(tetrahedra, where);
  result.element_size_m = tetrahedra.element_size_m;
  result.passes = tetrahedra.passes;
  result.count_error = tetrahedra.count_error;
  result.unused_nodes_dropped = sim::RemoveUnusedNodes(&result.mesh);
  sim::OrientElements(&result.mesh);
  return result;
}

void WriteMshInGmsh(const gmsh_module::MshFile& file, const std::string& where, const std::string& fix) {
  if (std::string failure = Module().write_msh(file); !failure.empty()) throw Error(failure, where, fix);
}

}  // namespace dg::io
