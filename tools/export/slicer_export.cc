#include "tools/export/slicer_export.h"

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <Eigen/Geometry>

#include "io/gmsh_reader.h"
#include "io/output_folder.h"
#include "io/registration_file.h"
#include "io/scene.h"
#include "io/surface_mesh.h"
#include "io/surface_mesh_reader.h"
#include "pipeline/scene_geometry.h"
#include "sim/error.h"
#include "sim/tet_mesh.h"
#include "tools/export/itk_slicer_files.h"
#include "tools/export/vtk_model_files.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;

constexpr double kMmPerM = 1000.0;
constexpr const char* kCommand = "dynaguide export slicer";
constexpr const char* kTransformName = "registration.tfm";
constexpr const char* kCtName = "ct_phase_00.mhd";

// What this command writes, as the output folder's claim removes an earlier export's files.
const std::vector<std::string> kOutputNames = {"surface_*.vtk",    "internal_*.vtk", "mesh.vtu",
                                               "mesh_surface.vtk", kTransformName,   kCtName,
                                               "ct_phase_00.raw",  "README.txt"};

// The registration file the export uses: --registration, else the scene's.
std::string RegistrationFile(const SlicerExportOptions& options, const io::Scene& scene) {
  if (!options.registration.empty()) return options.registration;
  if (scene.registration && !scene.registration->file.empty()) return scene.registration->file;
  throw Error("no registration to export: the scene names no registration file and --registration is not given",
              scene.path,
              "register first, `dynaguide register SCENE --out registration.yaml` (or use the registration.yaml that "
              "`dynaguide run SCENE --out DIR` writes), then give --registration registration.yaml or name it in the "
              "scene as registration: {file: registration.yaml}");
}

std::string Stem(const std::string& path) { return fs::path(path).stem().string(); }

// Upper-left 3x3 kept, translation scaled: the same rigid map in millimetres.
Eigen::Matrix4d InMillimetres(const Eigen::Matrix4d& T_m) {
  Eigen::Matrix4d T_mm = T_m;
  T_mm.block<3, 1>(0, 3) *= kMmPerM;
  return T_mm;
}

std::string Count(long long n, const char* what) { return std::to_string(n) + " " + what; }

}  // namespace

SlicerExport ExportForSlicer(const SlicerExportOptions& options) {
  const io::Scene scene = io::ReadScene(options.scene);
  if (!scene.overlays || (scene.overlays->surface_mesh.empty() && scene.overlays->internal_meshes.empty())) {
    throw Error("the scene has no overlay meshes to export", scene.path,
                "name the CT's meshes in the scene, overlays: {surface_mesh: skin.obj, internal_meshes: [a.obj]}, "
                "in the CT's frame (`dynaguide preop` writes them)");
  }
  SlicerExport exported;
  exported.out_dir = options.out_dir;
  exported.registration_source = fs::absolute(RegistrationFile(options, scene)).lexically_normal().string();
  const io::Registration registration = io::ReadRegistrationYaml(exported.registration_source);
  exported.T_C_S_mm = InMillimetres(registration.T_C_S);

  // Everything is read and checked before the folder is touched.
  const sim::TetMesh mesh = io::ReadGmsh(scene.mesh.file, scene.mesh.metres_per_unit);
  pipeline::CheckSceneGeometry(scene, mesh);
  struct Model {
    std::string name, what;
    io::SurfaceMesh surface;
  };
  std::vector<Model> models;
  // As the run reads and checks them: any format io::ReadSurfaceMesh takes, in overlays: units.
  const auto read_overlay = [&](const std::string& file) {
    io::SurfaceMesh surface = io::ReadSurfaceMesh(file, {scene.overlays->metres_per_unit, ""});
    pipeline::CheckOverlayMeshSize(scene, file, surface, mesh);
    return surface;
  };
  if (!scene.overlays->surface_mesh.empty()) {
    const std::string& file = scene.overlays->surface_mesh;
    models.push_back({"surface_" + Stem(file) + ".vtk", "surface mesh " + file, read_overlay(file)});
  }
  for (size_t k = 0; k < scene.overlays->internal_meshes.size(); ++k) {
    const std::string& file = scene.overlays->internal_meshes[k];
    models.push_back(
        {"internal_" + std::to_string(k + 1) + "_" + Stem(file) + ".vtk", "internal mesh " + file, read_overlay(file)});
  }
  const std::string ct =
      scene.preoperative && !scene.preoperative->ct_volumes.empty() ? scene.preoperative->ct_volumes.front() : "";

  const io::OutputFolderClaim claim(options.out_dir, kCommand, kOutputNames, {exported.registration_source});
  const auto path = [&](const std::string& name) { return (fs::path(options.out_dir) / name).string(); };
  const auto add = [&](const std::string& name, const std::string& what) { exported.files.push_back({name, what}); };

  for (const Model& model : models) {
    WriteVtkPolyData(path(model.name), model.surface.vertices_m * kMmPerM, model.surface.triangles,
                     "dynaguide " + Stem(model.name));
    add(model.name, model.what + ": " + Count(model.surface.num_vertices(), "vertices") + ", " +
                        Count(model.surface.num_triangles(), "triangles"));
    exported.models.push_back(model.name);
  }
  const Eigen::Matrix3Xd nodes_mm = mesh.X_m * kMmPerM;
  WriteVtuTetrahedra(path("mesh.vtu"), nodes_mm, mesh.tets);
  add("mesh.vtu", "simulation mesh " + scene.mesh.file + ": " + Count(mesh.num_nodes(), "nodes") + ", " +
                      Count(mesh.num_tets(), "tetrahedra"));
  exported.models.push_back("mesh.vtu");
  const Eigen::Matrix3Xi boundary = sim::BoundaryFaces(mesh);
  WriteVtkPolyData(path("mesh_surface.vtk"), nodes_mm, boundary, "dynaguide simulation mesh boundary");
  add("mesh_surface.vtk", "the simulation mesh's boundary: " + Count(boundary.cols(), "triangles") +
                              " on its " + Count(mesh.num_nodes(), "nodes") + " (unused ones included)");
  exported.models.push_back("mesh_surface.vtk");

  WriteItkAffineTransform(path(kTransformName), Eigen::Isometry3d(exported.T_C_S_mm).inverse().matrix());
  add(kTransformName, "the registration " + exported.registration_source +
                          ": T_S_C (camera to scan, mm) in the file, so Slicer's 'to parent' is T_C_S");
  exported.transform_file = kTransformName;

  if (!ct.empty()) {
    const ImageGeometryMm grid = RewriteAsMetaImage(ct, path(kCtName));
    char line[160];
    std::snprintf(line, sizeof line, "%dx%dx%d voxels of %.4g x %.4g x %.4g mm, origin (%.4g, %.4g, %.4g) mm",
                  grid.size.x(), grid.size.y(), grid.size.z(), grid.spacing_mm.x(), grid.spacing_mm.y(),
                  grid.spacing_mm.z(), grid.origin_mm.x(), grid.origin_mm.y(), grid.origin_mm.z());
    add(kCtName, "CT phase 0 " + ct + ": " + line + " (voxels in ct_phase_00.raw)");
    exported.ct_file = kCtName;
  }

  add("README.txt", "this list, and how to load the files in 3D Slicer");
  std::ofstream readme(path("README.txt"));
  readme << SlicerReadme(exported);
  readme.close();
  if (!readme) {
    throw Error("cannot write README.txt", path("README.txt"), "check that the output folder is writable");
  }
  return exported;
}

}  // namespace dg::tools
