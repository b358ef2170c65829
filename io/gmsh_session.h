#pragma once

#include <functional>
#include <mutex>
#include <string>

namespace dg::io {

// One use of Gmsh's SDK, from initialize to finalize. Gmsh keeps its state in
// process-wide singletons, so a session holds a process-wide mutex
// throughout: sessions on several threads run one after another. Every
// session meshes the same way whatever the user's set-up: config files are
// skipped (a user's gmshrc cannot change a mesh), Gmsh prints nothing and
// meshes on one thread with a fixed seed, 3D Delaunay with Gmsh's optimiser,
// linear elements, the size from MeshSizeMin/Max alone (so an element count
// follows the size). Run() turns whatever Gmsh throws (in 4.8 often a bare
// std::string, or a type with only the logger's last error to explain it)
// into a dg::Error naming the step, `where` and `fix`.
class GmshSession {
 public:
  // Gmsh's 2D algorithms that the project uses for surfaces.
  enum class SurfaceAlgorithm {
    kDelaunay = 5,        // CAD surfaces (io/gmsh_mesher)
    kFrontalDelaunay = 6  // reparametrised patches of a discrete surface (stages/preop)
  };

  GmshSession(std::string where, std::string fix, SurfaceAlgorithm surface = SurfaceAlgorithm::kDelaunay);
  ~GmshSession();
  GmshSession(const GmshSession&) = delete;
  GmshSession& operator=(const GmshSession&) = delete;

  void Run(const std::string& step, const std::function<void()>& body);

 private:
  std::lock_guard<std::mutex> lock_;
  std::string where_, fix_;
};

}  // namespace dg::io
