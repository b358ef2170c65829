#pragma once

#include <string>

#include "io/scene.h"

namespace dg::tools {

// A phantom's mesh at another resolution, for `dynaguide eval runtime`: the
// phantom's own shape meshed by Gmsh to about `target_tets` elements, and its
// preoperative motion recorded anew for that mesh's nodes (the analytic
// motion of the phantom's preset at the scan's phases), so that a scene can
// name both instead of its own mesh.msh and scan.h5. Everything else of the
// scene (truth, overlays, CT, video) is in the scan frame and independent of
// the mesh: the overlays and the truth's internal points are embedded into
// whichever mesh a run loads.
struct MeshVariant {
  std::string mesh_file, scan_file;  // beside the scene, named relative to it
};

// Writes runtime-mesh-<target>.msh and runtime-scan-<target>.h5 beside the
// scene (reused when both exist: meshing is deterministic), after checking
// that the preset's motion reproduces the scene's own scan on its own mesh.
// Leaves the phantom generator alone: it meshes through io/gmsh_mesher with
// the preset's shape, as the generator does.
// @throws dg::Error for a scene without truth (preset and seed) or scan, a
// scene whose motion is not its preset's (a phantom generated with
// overrides), or a file that cannot be written.
MeshVariant PhantomMeshVariant(const io::Scene& scene, int target_tets);

}  // namespace dg::tools
