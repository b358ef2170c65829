#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace dg::tools {

// `dynaguide export slicer`: a scene's geometry, phase-0 CT and registration
// in the files 3D Slicer loads, so that a user can lay the meshes over the CT
// and see where the registration puts them. Everything is in millimetres;
// meshes and CT stay in the scan frame S (LPS for a CT read from DICOM: the
// frame ITK and Slicer give the CT), and the registration is the one
// transform that carries them into the left camera frame C.
struct SlicerExportOptions {
  std::string scene;         // scene.yaml
  std::string out_dir;       // created when missing
  std::string registration;  // a registration YAML; empty: the scene's registration: {file: ...}
};

// One file written into the output folder.
struct ExportedFile {
  std::string name;  // within the output folder
  std::string what;  // one line for the listing and the README
};

struct SlicerExport {
  std::string out_dir;
  std::vector<ExportedFile> files;  // in the order written, README.txt last
  std::string registration_source;  // the registration YAML read
  Eigen::Matrix4d T_C_S_mm = Eigen::Matrix4d::Identity();  // scan frame S to camera frame C, millimetres
  std::string transform_file;       // the .tfm among files
  std::string ct_file;              // the .mhd among files; empty when the scene has no CT
  std::vector<std::string> models;  // the .vtk/.vtu among files, in the order written
};

// The files (names within the output folder), each with what it holds:
// - surface_<stem>.vtk and internal_<k>_<stem>.vtk: the scene's overlay
//   meshes (overlays: surface_mesh, internal_meshes) as legacy VTK polydata;
// - mesh.vtu, the simulation's tetrahedral mesh (mesh: file), and
//   mesh_surface.vtk, its boundary triangles;
// - registration.tfm: the registration as an ITK transform file. It holds
//   T_S_C = inverse(T_C_S) in millimetres, ITK's resampling sense with the
//   camera frame fixed and the scan frame moving, so that Slicer, which reads
//   a transform file as "from parent", makes T_C_S its "to parent": models
//   and CT placed under it move from S into C;
// - ct_phase_00.mhd and .raw: the first CT phase rewritten through ITK, its
//   spacing and origin in millimetres, when the scene has a CT;
// - README.txt: the files and how to load them in Slicer.
// Before anything is written the scene's geometry is checked for one frame
// and unit (pipeline::CheckSceneGeometry: mesh size, mesh inside the CT's grid).
// @throws dg::Error for a scene without overlay meshes, a missing
//   registration (naming the commands that write one), an unreadable input,
//   or an output folder that cannot be created or written, each with a fix.
SlicerExport ExportForSlicer(const SlicerExportOptions& options);

// README.txt's text: what each file holds and how to load them in Slicer.
std::string SlicerReadme(const SlicerExport& exported);

}  // namespace dg::tools
