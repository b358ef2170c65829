// `dynaguide export slicer` on the tiny phantom, read back by the libraries
// 3D Slicer itself reads these files with: VTK's readers for the models (the
// scene's meshes x 1000, LPS named as Slicer names it), ITK's transform reader
// for the registration (the truth's T_C_S in millimetres, inverted as Slicer
// reads it), ITK's image reader for the CT (millimetres); and the inputs an
// export cannot use are refused with a fix before the folder is touched.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <utility>

#include <catch2/catch.hpp>
// Debian's ITK carries its own Eigen under Eigen's include guards: the system's first.
#include <Eigen/Dense>
#include <itkAffineTransform.h>
#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkTransformFileReader.h>
#include <itkTxtTransformIOFactory.h>
#include <vtkCellArray.h>
#include <vtkCellType.h>
#include <vtkFieldData.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataReader.h>
#include <vtkPolyDataWriter.h>
#include <vtkStringArray.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>
#include <yaml-cpp/yaml.h>

#include "io/ct/itk_factories.h"
#include "io/gmsh_reader.h"
#include "io/h5_file.h"
#include "io/registration_file.h"
#include "io/scene.h"
#include "io/surface_mesh.h"
#include "sim/error.h"
#include "sim/tet_mesh.h"
#include "tests/support/temporary_folder.h"
#include "tests/support/tiny_phantom.h"
#include "tools/export/slicer_export.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;
using Catch::Matchers::Contains;

std::string TinyScene() { return dg::testing::TinyPhantomDir() + "/scene.yaml"; }

// The truth's registration, in the file `dynaguide register --out` writes.
std::string TruthRegistration(const std::string& folder) {
  const io::H5Reader truth(dg::testing::TinyPhantomDir() + "/truth.h5");
  io::Registration registration;
  registration.T_C_S = truth.ReadMatrix("/T_C_S");
  registration.phase_shift_s = truth.ReadScalar("/phase_shift_s");
  registration.period_s = truth.ReadScalar("/period_s");
  const std::string path = folder + "/registration.yaml";
  io::WriteRegistrationYaml(path, registration);
  return path;
}

double Relative(const Eigen::Vector3d& got, const Eigen::Vector3d& want) {
  return (got - want).norm() / std::max(want.norm(), 1.0);
}

// The largest relative difference of a VTK point set from points_mm, after
// checking that it holds as many points.
double LargestDeparture(vtkPoints* points, const Eigen::Matrix3Xd& points_mm) {
  REQUIRE(points != nullptr);
  REQUIRE(points->GetNumberOfPoints() == points_mm.cols());
  double worst = 0;
  for (Eigen::Index i = 0; i < points_mm.cols(); ++i) {
    double p[3];
    points->GetPoint(i, p);
    worst = std::max(worst, Relative(Eigen::Vector3d(p[0], p[1], p[2]), points_mm.col(i)));
  }
  return worst;
}

// Reads a legacy .vtk model the way Slicer does; checks its frame tag.
vtkSmartPointer<vtkPolyData> ReadLegacyModel(const std::string& path) {
  vtkNew<vtkPolyDataReader> reader;
  reader->SetFileName(path.c_str());
  REQUIRE(reader->IsFilePolyData() == 1);
  reader->Update();
  REQUIRE(reader->GetErrorCode() == 0);
  REQUIRE_THAT(std::string(reader->GetHeader()), Contains("SPACE=LPS") && Contains("millimetres"));
  return reader->GetOutput();
}

void RequireSameTriangles(vtkPolyData* model, const Eigen::Matrix3Xi& triangles) {
  REQUIRE(model->GetNumberOfPolys() == triangles.cols());
  vtkCellArray* polys = model->GetPolys();
  vtkNew<vtkIdList> corners;
  for (Eigen::Index t = 0; t < triangles.cols(); ++t) {
    polys->GetCellAtId(t, corners);
    REQUIRE(corners->GetNumberOfIds() == 3);
    for (int c = 0; c < 3; ++c) REQUIRE(corners->GetId(c) == triangles(c, t));
  }
}

TEST_CASE("export slicer: the tiny phantom's models, registration and CT read back through VTK and ITK",
          "[tools][integration]") {
  const dg::testing::TemporaryFolder folder("dg_export_test");
  const io::Scene scene = io::ReadScene(TinyScene());
  SlicerExportOptions options;
  options.scene = TinyScene();
  options.out_dir = folder.path() + "/slicer";
  options.registration = TruthRegistration(folder.path());
  const SlicerExport exported = ExportForSlicer(options);
  const auto out = [&](const std::string& name) { return options.out_dir + "/" + name; };

  SECTION("the overlay meshes: every vertex x 1000, every triangle, in LPS") {
    std::vector<std::pair<std::string, std::string>> models = {{"surface_skin.vtk", scene.overlays->surface_mesh}};
    for (size_t k = 0; k < scene.overlays->internal_meshes.size(); ++k) {
      const std::string& file = scene.overlays->internal_meshes[k];
      models.emplace_back("internal_" + std::to_string(k + 1) + "_" + fs::path(file).stem().string() + ".vtk", file);
    }
    REQUIRE(models.size() == 3);
    for (const auto& [name, source] : models) {
      INFO(name);
      const io::SurfaceMesh original = io::ReadObj(source);
      const vtkSmartPointer<vtkPolyData> model = ReadLegacyModel(out(name));
      // Binary doubles: read back bit for bit.
      CHECK(LargestDeparture(model->GetPoints(), original.vertices_m * 1000.0) == 0.0);
      RequireSameTriangles(model, original.triangles);
    }
  }

  SECTION("the simulation mesh: its tetrahedra in .vtu, its closed boundary in .vtk") {
    const sim::TetMesh mesh = io::ReadGmsh(scene.mesh.file, scene.mesh.metres_per_unit);
    vtkNew<vtkXMLUnstructuredGridReader> reader;
    reader->SetFileName(out("mesh.vtu").c_str());
    reader->Update();
    vtkUnstructuredGrid* grid = reader->GetOutput();
    CHECK(LargestDeparture(grid->GetPoints(), mesh.X_m * 1000.0) == 0.0);
    REQUIRE(grid->GetNumberOfCells() == mesh.num_tets());
    for (vtkIdType e = 0; e < grid->GetNumberOfCells(); ++e) {
      REQUIRE(grid->GetCellType(e) == VTK_TETRA);
      vtkIdType n = 0;
      const vtkIdType* corners = nullptr;
      grid->GetCellPoints(e, n, corners);
      for (int c = 0; c < 4; ++c) REQUIRE(corners[c] == mesh.tets(c, e));
    }
    auto* space = vtkStringArray::SafeDownCast(grid->GetFieldData()->GetAbstractArray("SPACE"));
    REQUIRE(space != nullptr);
    REQUIRE(space->GetValue(0) == "LPS");

    const vtkSmartPointer<vtkPolyData> boundary = ReadLegacyModel(out("mesh_surface.vtk"));
    CHECK(LargestDeparture(boundary->GetPoints(), mesh.X_m * 1000.0) == 0.0);
    // The boundary of a solid is closed: each of its edges borders exactly two of its triangles.
    std::map<std::pair<vtkIdType, vtkIdType>, int> edges;
    vtkNew<vtkIdList> corners;
    for (vtkIdType t = 0; t < boundary->GetNumberOfPolys(); ++t) {
      boundary->GetPolys()->GetCellAtId(t, corners);
      for (int c = 0; c < 3; ++c) {
        const vtkIdType a = corners->GetId(c), b = corners->GetId((c + 1) % 3);
        ++edges[{std::min(a, b), std::max(a, b)}];
      }
    }
    REQUIRE(boundary->GetNumberOfPolys() > 100);
    CHECK(std::all_of(edges.begin(), edges.end(), [](const auto& edge) { return edge.second == 2; }));
  }

  SECTION("the transform file maps camera to scan; its inverse carries the fiducials as the true T_C_S does") {
    const io::H5Reader truth(dg::testing::TinyPhantomDir() + "/truth.h5");
    const Eigen::Matrix4d T_C_S = truth.ReadMatrix("/T_C_S");
    const Eigen::MatrixXd fiducials_S_m = truth.ReadMatrix("/fiducials/X_S_m");  // one row per fiducial
    REQUIRE(fiducials_S_m.rows() == 6);

    itk::TxtTransformIOFactory::RegisterOneFactory();
    auto reader = itk::TransformFileReaderTemplate<double>::New();
    reader->SetFileName(out("registration.tfm"));
    reader->Update();
    REQUIRE(reader->GetTransformList()->size() == 1);
    using Affine = itk::AffineTransform<double, 3>;
    const Affine::Pointer file = dynamic_cast<Affine*>(reader->GetTransformList()->front().GetPointer());
    REQUIRE(file);
    const Affine::Pointer file_inverse = Affine::New();
    REQUIRE(file->GetInverse(file_inverse));
    double worst_forward = 0, worst_inverse = 0;
    for (Eigen::Index f = 0; f < fiducials_S_m.rows(); ++f) {
      const Eigen::Vector3d X_S_mm = 1000.0 * fiducials_S_m.row(f).transpose();
      const Eigen::Vector3d x_C_mm = 1000.0 * (T_C_S.topLeftCorner<3, 3>() * fiducials_S_m.row(f).transpose() +
                                               T_C_S.topRightCorner<3, 1>());
      const Affine::OutputPointType to_scan = file->TransformPoint(Affine::InputPointType(x_C_mm.data()));
      const Affine::OutputPointType to_camera = file_inverse->TransformPoint(Affine::InputPointType(X_S_mm.data()));
      worst_forward = std::max(worst_forward, Relative(Eigen::Vector3d(to_scan.GetDataPointer()), X_S_mm));
      worst_inverse = std::max(worst_inverse, Relative(Eigen::Vector3d(to_camera.GetDataPointer()), x_C_mm));
    }
    // ITK prints each number so that it reads back as the same double: measured 4e-16 and 3e-16.
    CHECK(worst_forward <= 1e-14);
    CHECK(worst_inverse <= 1e-14);
  }

  SECTION("the CT: the phase-0 voxels, spacing and origin in millimetres as ITK reads them") {
    io::RegisterItkImageIo();
    using Image = itk::Image<short, 3>;
    const auto read = [](const std::string& path) {
      auto reader = itk::ImageFileReader<Image>::New();
      reader->SetFileName(path);
      reader->Update();
      return Image::Pointer(reader->GetOutput());
    };
    const Image::Pointer exported_ct = read(out("ct_phase_00.mhd"));
    const Image::Pointer original = read(scene.preoperative->ct_volumes.front());
    for (int a = 0; a < 3; ++a) {
      CHECK(exported_ct->GetSpacing()[a] == 1.5);  // the tiny preset's voxel, 1.5 mm
      CHECK(exported_ct->GetOrigin()[a] == original->GetOrigin()[a]);
      CHECK(exported_ct->GetLargestPossibleRegion().GetSize()[a] == original->GetLargestPossibleRegion().GetSize()[a]);
    }
    CHECK(exported_ct->GetDirection().GetVnlMatrix().is_identity());
    const size_t voxels = exported_ct->GetLargestPossibleRegion().GetNumberOfPixels();
    CHECK(std::equal(exported_ct->GetBufferPointer(), exported_ct->GetBufferPointer() + voxels,
                     original->GetBufferPointer()));
    // Millimetres: the mesh (metres x 1000) lies inside the CT's physical extent.
    const sim::TetMesh mesh = io::ReadGmsh(scene.mesh.file, scene.mesh.metres_per_unit);
    Image::PointType low, high;
    Image::IndexType last;
    for (int a = 0; a < 3; ++a) last[a] = exported_ct->GetLargestPossibleRegion().GetSize()[a] - 1;
    exported_ct->TransformIndexToPhysicalPoint(exported_ct->GetLargestPossibleRegion().GetIndex(), low);
    exported_ct->TransformIndexToPhysicalPoint(last, high);
    for (int a = 0; a < 3; ++a) {
      CHECK(1000.0 * mesh.X_m.row(a).minCoeff() >= low[a]);
      CHECK(1000.0 * mesh.X_m.row(a).maxCoeff() <= high[a]);
    }
  }

  SECTION("README.txt names every file and the transform's direction") {
    std::stringstream readme;
    readme << std::ifstream(out("README.txt")).rdbuf();
    for (const ExportedFile& file : exported.files) {
      CHECK(fs::exists(out(file.name)));
      CHECK_THAT(readme.str(), Contains(file.name));
    }
    CHECK(exported.files.size() == 8);  // 3 overlays, mesh.vtu, mesh_surface.vtk, .tfm, .mhd, README
    CHECK_THAT(readme.str(), Contains("T_S_C") && Contains("to parent") && Contains("SPACE=LPS"));
  }
}

// A user's mesh in millimetres (written by VTK's own writer, the scene saying
// overlays: {units: mm}) leaves the export with the file's own coordinates.
TEST_CASE("export slicer: an overlay mesh in millimetres keeps its coordinates", "[tools][integration]") {
  const dg::testing::TemporaryFolder folder("dg_export_test");
  const std::string phantom = dg::testing::TinyPhantomDir();
  const io::SurfaceMesh chamber = io::ReadObj(phantom + "/assets/chamber_0.obj");
  const Eigen::Matrix3Xd chamber_mm = chamber.vertices_m * 1000.0;
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  for (Eigen::Index i = 0; i < chamber_mm.cols(); ++i) {
    points->InsertNextPoint(chamber_mm(0, i), chamber_mm(1, i), chamber_mm(2, i));
  }
  vtkNew<vtkCellArray> triangles;
  for (Eigen::Index t = 0; t < chamber.triangles.cols(); ++t) {
    const vtkIdType corners[3] = {chamber.triangles(0, t), chamber.triangles(1, t), chamber.triangles(2, t)};
    triangles->InsertNextCell(3, corners);
  }
  vtkNew<vtkPolyData> surface;
  surface->SetPoints(points);
  surface->SetPolys(triangles);
  vtkNew<vtkPolyDataWriter> writer;
  writer->SetFileName((phantom + "/assets/chamber_0_mm.vtk").c_str());
  writer->SetInputData(surface);
  writer->SetFileTypeToBinary();
  REQUIRE(writer->Write() == 1);

  YAML::Node root = YAML::LoadFile(TinyScene());
  root.remove("overlays");
  root["overlays"]["units"] = "mm";
  root["overlays"]["internal_meshes"].push_back("assets/chamber_0_mm.vtk");
  SlicerExportOptions options;
  options.scene = phantom + "/export-mm.yaml";
  std::ofstream(options.scene) << root;
  options.out_dir = folder.path() + "/slicer";
  options.registration = TruthRegistration(folder.path());
  const SlicerExport exported = ExportForSlicer(options);
  REQUIRE(exported.models.front() == "internal_1_chamber_0_mm.vtk");

  const vtkSmartPointer<vtkPolyData> model = ReadLegacyModel(options.out_dir + "/internal_1_chamber_0_mm.vtk");
  // Millimetres to metres and back: two roundings (measured 2.1e-16 relative).
  CHECK(LargestDeparture(model->GetPoints(), chamber_mm) <= 5e-16);
  RequireSameTriangles(model, chamber.triangles);
}

// What the export cannot use is refused, naming the fix, before the folder is created.
TEST_CASE("export slicer: a missing registration, a scene without overlays and an unwritable folder are refused",
          "[tools][integration]") {
  const dg::testing::TemporaryFolder folder("dg_export_test");
  SlicerExportOptions options;
  options.scene = TinyScene();
  options.out_dir = folder.path() + "/slicer";

  SECTION("no registration: the commands that write one") {
    try {
      ExportForSlicer(options);
      FAIL("exported without a registration");
    } catch (const Error& e) {
      CHECK_THAT(e.problem(), Contains("no registration"));
      CHECK(e.where() == io::ReadScene(TinyScene()).path);
      CHECK_THAT(e.fix(), Contains("dynaguide register SCENE --out registration.yaml") && Contains("--registration"));
    }
    CHECK_FALSE(fs::exists(options.out_dir));
  }

  SECTION("no overlays: where to name them") {
    YAML::Node root = YAML::LoadFile(TinyScene());
    root.remove("overlays");
    options.scene = dg::testing::TinyPhantomDir() + "/export-no-overlays.yaml";
    std::ofstream(options.scene) << root;
    options.registration = TruthRegistration(folder.path());
    try {
      ExportForSlicer(options);
      FAIL("exported a scene without overlays");
    } catch (const Error& e) {
      CHECK_THAT(e.problem(), Contains("no overlay meshes"));
      CHECK_THAT(e.fix(), Contains("overlays: {surface_mesh:"));
    }
    CHECK_FALSE(fs::exists(options.out_dir));
  }

  SECTION("an output folder under a file") {
    options.registration = TruthRegistration(folder.path());
    options.out_dir = options.registration + "/slicer";
    try {
      ExportForSlicer(options);
      FAIL("exported under a file");
    } catch (const Error& e) {
      CHECK_THAT(e.problem(), Contains("cannot create the output folder"));
      CHECK(e.where() == options.out_dir);
      CHECK_THAT(e.fix(), Contains("check the path"));
    }
  }
}

}  // namespace
}  // namespace dg::tools
