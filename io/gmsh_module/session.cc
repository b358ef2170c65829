#include "io/gmsh_module/session.h"

#include <string>
#include <vector>

#include <gmsh.h>

namespace dg::io::gmsh_module {
namespace {

std::mutex& GmshMutex() {
  static std::mutex mutex;
  return mutex;
}

}  // namespace

Session::Session(SurfaceAlgorithm surface) : lock_(GmshMutex()) {
  gmsh::initialize(0, nullptr, /*readConfigFiles=*/false);
  try {
    Run("configuring Gmsh", [surface] {
      gmsh::option::setNumber("General.Terminal", 0);
      gmsh::logger::start();  // keeps messages for getLastError
      gmsh::option::setNumber("General.NumThreads", 1);
      gmsh::option::setNumber("Mesh.RandomSeed", 1);
      // The surface algorithm is the caller's (module.cc says why). HXT
      // (Algorithm3D = 10) is faster than Delaunay but gave a different mesh
      // on each run, even on one thread.
      gmsh::option::setNumber("Mesh.Algorithm", static_cast<int>(surface));
      gmsh::option::setNumber("Mesh.Algorithm3D", 1);
      gmsh::option::setNumber("Mesh.Optimize", 1);
      gmsh::option::setNumber("Mesh.ElementOrder", 1);
      gmsh::option::setNumber("Mesh.MeshSizeFromPoints", 0);
      gmsh::option::setNumber("Mesh.MeshSizeFromCurvature", 0);
      gmsh::option::setNumber("Mesh.MeshSizeExtendFromBoundary", 0);
    });
  } catch (...) {
    gmsh::finalize();
    throw;
  }
}

Session::~Session() { gmsh::finalize(); }

void Session::Mesh(const std::function<void()>& call) {
  gmsh::logger::stop();  // a restart empties the log
  gmsh::logger::start();
  gmsh::option::setNumber("General.AbortOnError", 1);
  try {
    call();
  } catch (...) {
    gmsh::option::setNumber("General.AbortOnError", 2);
    throw;
  }
  gmsh::option::setNumber("General.AbortOnError", 2);  // Gmsh's default: throw
  std::vector<std::string> log;
  gmsh::logger::get(log);
  std::string errors;
  for (const std::string& line : log) {
    if (line.rfind("Error", 0) == 0) errors += (errors.empty() ? "" : "; ") + line;
  }
  if (!errors.empty()) throw errors;
}

void Session::Run(const std::string& step, const std::function<void()>& body) {
  std::string reason;
  try {
    body();
    return;
  } catch (const std::string& message) {
    reason = message;
  } catch (const std::exception& e) {
    reason = e.what();
  } catch (...) {
    gmsh::logger::getLastError(reason);
  }
  if (reason.empty()) reason = "no message";
  throw StepFailed(step + " failed in Gmsh: " + reason);
}

}  // namespace dg::io::gmsh_module
