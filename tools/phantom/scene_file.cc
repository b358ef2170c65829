#include "tools/phantom/scene_file.h"

#include <cstdio>
#include <fstream>

#include "sim/error.h"

namespace dg::tools::phantom {

namespace {

// Two cycles register well and leave the rest of a 3.5 s video to
// the simulation; a shorter video registers over one.
int RegistrationCycles(double video_s, double period_s) {
  return video_s >= 4 * period_s ? 2 : 1;
}

// The scene names the MetaImages when they are written: the scene's readers
// take MetaImages. The DICOM series are for `dynaguide preop` (and any
// viewer); without MetaImages the scene has no CT, so no volume overlay.
std::string CtLines(const PhantomSpec& spec) {
  std::string lines;
  if (spec.writes_metaimage()) lines += "  ct: ct/phase_%02d.mhd    # MetaImage, one per phase (printf pattern)\n";
  if (spec.writes_dicom()) lines += "  # the same CT as DICOM: a series per phase in ct/dicom/phase_NN/, one study\n";
  return lines;
}

}  // namespace

void WriteSceneFile(const std::string& path, const PhantomSpec& spec, int frames, double period_s) {
  std::ofstream out(path);
  if (!out) throw Error("cannot write the scene file", path, "check the output directory is writable");
  char text[4096];
  std::snprintf(text, sizeof text,
                R"(# A dynaguide scene written by `dynaguide phantom --preset %s --seed %llu`.
# Paths are relative to this file; lengths in metres, times in seconds.
name: phantom-%s-seed%llu
mesh:
  file: mesh.msh           # Gmsh 4.1, metres; physical groups surface, base, body
  units: m
  fixed_set: base          # the nodes on the mount
  surface_set: surface
material:
  youngs_modulus_pa: %.6g
  poissons_ratio: %.6g
  density_kg_m3: %.6g
preoperative:
  period_s: %.9g           # the 4D CT's cardiac period
  phases: %d               # uniformly spaced over one cycle, phase k at k / phases
  motion: scan.h5          # /phases/node_displacement_m [phase, node, xyz], /phases/fiducials_S_m
%soverlays:
  surface_mesh: assets/skin.obj
  surface_texture: assets/skin_texture.png
  internal_meshes: [assets/chamber_0.obj, assets/chamber_1.obj]
  internal_points: scan.h5:/internal_points_S_m
calibration: calibration.yaml
calibration_images: calibration/%%s_%%02d.png   # left/right, %d pairs
video:
  left: video/left.avi
  right: video/right.avi
  fps: %.9g
  frames: %d
registration:
  cycles: %d                # the video's first cycles register the scan to it (paper section 2.2)
simulation:
  mode: combined           # surface, volume or combined (paper section 2.6)
  dt_s: 2.0e-4
  damping_per_s: 75
truth: truth.h5            # ground truth; a real recording has none
# truth/dvf_phase_NN.mha: the exact displacement from phase 0 to phase NN on the CT's grid (mm)
)",
                spec.preset.c_str(), static_cast<unsigned long long>(spec.seed), spec.preset.c_str(),
                static_cast<unsigned long long>(spec.seed), spec.material.youngs_modulus_pa, spec.material.poissons_ratio,
                spec.material.density_kg_m3, period_s, spec.phases, CtLines(spec).c_str(), spec.chessboard_pairs,
                spec.fps, frames, RegistrationCycles(frames / spec.fps, period_s));
  out << text;
}

}  // namespace dg::tools::phantom
