#pragma once

#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>

namespace dg::io::gmsh_module {

// A step that failed inside Gmsh, with Gmsh's reason. Thrown and caught
// inside the module only: the entry points return its message.
class StepFailed : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One use of Gmsh's SDK, from initialize to finalize. Gmsh keeps its state in
// process-wide singletons, so a session holds a process-wide mutex
// throughout: sessions on several threads run one after another. Every
// session meshes the same way whatever the user's set-up: config files are
// skipped (a user's gmshrc cannot change a mesh), Gmsh prints nothing and
// meshes on one thread with a fixed seed, 3D Delaunay with Gmsh's optimiser,
// linear elements, the size from MeshSizeMin/Max alone (so an element count
// follows the size). Run() turns whatever Gmsh throws (in 4.8 often a bare
// std::string, or a type with only the logger's last error to explain it)
// into StepFailed naming the step.
class Session {
 public:
  // Gmsh's 2D algorithms that the project uses for surfaces.
  enum class SurfaceAlgorithm {
    kDelaunay = 5,        // CAD surfaces
    kFrontalDelaunay = 6  // reparametrised patches of a discrete surface
  };

  explicit Session(SurfaceAlgorithm surface = SurfaceAlgorithm::kDelaunay);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  void Run(const std::string& step, const std::function<void()>& body);

  // Calls one of Gmsh's meshing functions (generate, optimize), which run
  // OpenMP regions: an error Gmsh throws inside one ends the process
  // (std::terminate, rc 134), whatever catches it outside. So Gmsh is told
  // to stop meshing on an error instead of throwing (General.AbortOnError 1)
  // for the call, and an error in its log is thrown afterwards, outside the
  // region, as a std::string (as Gmsh's own throws).
  static void Mesh(const std::function<void()>& call);

 private:
  std::lock_guard<std::mutex> lock_;
};

}  // namespace dg::io::gmsh_module
