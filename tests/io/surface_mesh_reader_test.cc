// ReadSurfaceMesh on files written by VTK's own writers (the tools 3D Slicer
// and ParaView save meshes with): one octahedron in millimetres, as ASCII and
// binary PLY, STL, legacy VTK and VTK XML, read back in millimetres and in
// metres against its known vertices and volume. Unknown extensions, empty,
// garbled and cut-short files are named errors.
#include "io/surface_mesh_reader.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <vector>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <vtkCellArray.h>
#include <vtkDoubleArray.h>
#include <vtkFloatArray.h>
#include <vtkNew.h>
#include <vtkPLYWriter.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataWriter.h>
#include <vtkSTLWriter.h>
#include <vtkSmartPointer.h>
#include <vtkXMLPolyDataWriter.h>

#include "sim/error.h"

namespace dg::io {
namespace {

std::string OutputPath(const std::string& name) { return std::string(DG_BINARY_DIR) + "/" + name; }

// An octahedron about (12.5, -3.25, 40) mm, half-diagonals 21.3, 17.1 and
// 9.7 mm (values with no short binary form), outward triangles, a normal and
// a texture coordinate per vertex.
struct Octahedron {
  Eigen::Matrix3Xd vertices_mm{3, 6};
  Eigen::Matrix3Xi triangles{3, 8};
  Eigen::Matrix3Xd normals{3, 6};
  Eigen::Matrix2Xd uvs{2, 6};
  static constexpr double kA = 21.3, kB = 17.1, kC = 9.7;
  // The volume of |x/a| + |y/b| + |z/c| <= 1: 4/3 a b c.
  static constexpr double kVolumeMm3 = 4.0 / 3 * kA * kB * kC;

  Octahedron() {
    const Eigen::Vector3d centre(12.5, -3.25, 40);
    const Eigen::Vector3d axes[3] = {kA * Eigen::Vector3d::UnitX(), kB * Eigen::Vector3d::UnitY(),
                                     kC * Eigen::Vector3d::UnitZ()};
    for (int i = 0; i < 3; ++i) {
      vertices_mm.col(2 * i) = centre + axes[i];
      vertices_mm.col(2 * i + 1) = centre - axes[i];
      normals.col(2 * i) = axes[i].normalized();
      normals.col(2 * i + 1) = -axes[i].normalized();
    }
    // Vertex 0 +x, 1 -x, 2 +y, 3 -y, 4 +z, 5 -z; counter-clockwise from outside.
    triangles << 0, 2, 1, 3, 2, 0, 3, 1,  //
        2, 1, 3, 0, 0, 3, 1, 2,           //
        4, 4, 4, 4, 5, 5, 5, 5;
    for (int v = 0; v < 6; ++v) uvs.col(v) = Eigen::Vector2d(0.125 * v + 0.0625, 1 - 0.1 * v);
  }

  vtkSmartPointer<vtkPolyData> ToPolyData() const {
    vtkNew<vtkPoints> points;
    points->SetDataTypeToDouble();
    for (int v = 0; v < 6; ++v) points->InsertNextPoint(vertices_mm.col(v).data());
    vtkNew<vtkCellArray> cells;
    for (int t = 0; t < 8; ++t) {
      const vtkIdType corners[3] = {triangles(0, t), triangles(1, t), triangles(2, t)};
      cells->InsertNextCell(3, corners);
    }
    vtkNew<vtkDoubleArray> vtk_normals;
    vtkNew<vtkFloatArray> vtk_uvs;  // VTK's PLY writer writes float texture coordinates alone
    vtk_normals->SetNumberOfComponents(3);
    vtk_uvs->SetNumberOfComponents(2);
    for (int v = 0; v < 6; ++v) {
      vtk_normals->InsertNextTuple(normals.col(v).data());
      vtk_uvs->InsertNextTuple(uvs.col(v).data());
    }
    auto polydata = vtkSmartPointer<vtkPolyData>::New();
    polydata->SetPoints(points);
    polydata->SetPolys(cells);
    polydata->GetPointData()->SetNormals(vtk_normals);
    polydata->GetPointData()->SetTCoords(vtk_uvs);
    return polydata;
  }
};

// By the divergence theorem over outward triangles.
double Volume(const SurfaceMesh& mesh) {
  double volume = 0;
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    volume += mesh.vertices_m.col(mesh.triangles(0, t))
                  .dot(mesh.vertices_m.col(mesh.triangles(1, t)).cross(mesh.vertices_m.col(mesh.triangles(2, t))));
  }
  return volume / 6;
}

// Each triangle as its three corner positions, rotated to start at the
// smallest and the list sorted, to compare meshes whose vertices are numbered
// differently (STL repeats corners per facet).
std::vector<std::array<double, 9>> CornerSets(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles) {
  std::vector<std::array<double, 9>> sets;
  for (Eigen::Index t = 0; t < triangles.cols(); ++t) {
    std::array<std::array<double, 3>, 3> corners;
    for (int c = 0; c < 3; ++c) {
      for (int r = 0; r < 3; ++r) corners[c][r] = vertices(r, triangles(c, t));
    }
    std::rotate(corners.begin(), std::min_element(corners.begin(), corners.end()), corners.end());
    std::array<double, 9> set;
    for (int i = 0; i < 9; ++i) set[i] = corners[i / 3][i % 3];
    sets.push_back(set);
  }
  std::sort(sets.begin(), sets.end());
  return sets;
}

double LargestCornerGap(const SurfaceMesh& read, double units_per_metre, const Octahedron& truth) {
  const auto a = CornerSets(read.vertices_m * units_per_metre, read.triangles);
  const auto b = CornerSets(truth.vertices_mm, truth.triangles);
  REQUIRE(a.size() == b.size());
  double gap = 0;
  for (size_t t = 0; t < a.size(); ++t) {
    for (int i = 0; i < 9; ++i) gap = std::max(gap, std::abs(a[t][i] - b[t][i]));
  }
  return gap;
}

struct Written {
  std::string name;
  bool keeps_order_and_attributes;  // STL keeps neither
  bool has_normals;                 // VTK's PLY writer writes none
  double precision_mm;              // of the positions as written: float or double
};

// `test` names the file after the test case: CTest runs the cases as
// processes side by side, and one truncates what another reads.
Written Write(const std::string& kind, const Octahedron& octahedron, const std::string& test) {
  const vtkSmartPointer<vtkPolyData> polydata = octahedron.ToPolyData();
  const std::string path = OutputPath("surface_mesh_reader_" + test + "_" + kind);
  const auto write = [&](auto& writer) {
    writer->SetInputData(polydata);
    writer->SetFileName(path.c_str());
    REQUIRE(writer->Write() == 1);
  };
  const double as_float = 1e-5, as_double = 1e-12;  // relative to 50 mm coordinates
  if (kind == "ascii.ply" || kind == "binary.ply") {
    vtkNew<vtkPLYWriter> writer;
    if (kind == "ascii.ply") writer->SetFileTypeToASCII();
    else writer->SetFileTypeToBinary();
    write(writer);
    return {path, true, false, as_float};
  }
  if (kind == "ascii.stl" || kind == "binary.stl") {
    vtkNew<vtkSTLWriter> writer;
    if (kind == "ascii.stl") writer->SetFileTypeToASCII();
    else writer->SetFileTypeToBinary();
    write(writer);
    return {path, false, false, as_float};
  }
  if (kind == "ascii.vtk" || kind == "binary.vtk") {
    vtkNew<vtkPolyDataWriter> writer;
    if (kind == "ascii.vtk") writer->SetFileTypeToASCII();
    else writer->SetFileTypeToBinary();
    write(writer);
    return {path, true, true, as_double};
  }
  vtkNew<vtkXMLPolyDataWriter> writer;
  if (kind == "ascii.vtp") writer->SetDataModeToAscii();
  else writer->SetDataModeToAppended();
  write(writer);
  return {path, true, true, as_double};
}

Error ReadError(const std::string& path) {
  try {
    ReadSurfaceMesh(path, {1e-3, ""});
  } catch (const Error& error) {
    return error;
  }
  FAIL("no error reading " << path);
  throw;  // unreachable: FAIL throws
}

}  // namespace

TEST_CASE("surface_mesh_reader: files VTK's writers wrote, in mm and in m", "[io][unit]") {
  const Octahedron truth;
  for (const std::string kind : {"ascii.ply", "binary.ply", "ascii.stl", "binary.stl", "ascii.vtk", "binary.vtk",
                                 "ascii.vtp", "appended.vtp"}) {
    INFO(kind);
    const Written file = Write(kind, truth, "formats");
    const SurfaceMesh in_m = ReadSurfaceMesh(file.name, {1e-3, ""});
    const SurfaceMesh in_mm = ReadSurfaceMesh(file.name, {1.0, ""});
    REQUIRE(in_m.num_triangles() == 8);
    REQUIRE(in_m.num_vertices() == 6);  // STL's repeated corners merged
    REQUIRE(in_m.triangles == in_mm.triangles);
    CHECK(LargestCornerGap(in_m, 1e3, truth) < file.precision_mm);
    CHECK(LargestCornerGap(in_mm, 1, truth) < file.precision_mm);
    CHECK(Volume(in_m) == Approx(Octahedron::kVolumeMm3 * 1e-9).epsilon(1e-6));
    CHECK(Volume(in_mm) == Approx(Octahedron::kVolumeMm3).epsilon(1e-6));
    if (file.keeps_order_and_attributes) {
      REQUIRE(in_m.triangles == truth.triangles);
      CHECK((in_m.vertices_m * 1e3 - truth.vertices_mm).cwiseAbs().maxCoeff() < file.precision_mm);
      REQUIRE(in_m.normals.cols() == (file.has_normals ? 6 : 0));
      REQUIRE(in_m.uvs.cols() == 6);
      if (file.has_normals) CHECK((in_m.normals - truth.normals).cwiseAbs().maxCoeff() < 1e-7);
      CHECK((in_m.uvs - truth.uvs).cwiseAbs().maxCoeff() < 1e-7);
    } else {
      CHECK(in_m.normals.cols() == 0);
      CHECK(in_m.uvs.cols() == 0);
    }
  }
}

// The extension names the format, in any case; an unknown one is refused with the accepted list.
TEST_CASE("surface_mesh_reader: extensions", "[io][unit]") {
  const Written stl = Write("binary.stl", Octahedron(), "extensions");
  const std::string upper = OutputPath("surface_mesh_reader_upper.STL");
  std::filesystem::copy_file(stl.name, upper, std::filesystem::copy_options::overwrite_existing);
  REQUIRE(IsSurfaceMeshFile(upper));
  REQUIRE(ReadSurfaceMesh(upper).num_triangles() == 8);

  const std::string off = OutputPath("surface_mesh_reader.off");
  std::ofstream(off) << "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  REQUIRE_FALSE(IsSurfaceMeshFile(off));
  const Error error = ReadError(off);
  CHECK(error.where() == off);
  CHECK_THAT(error.problem(), Catch::Contains("unknown surface mesh format '.off'"));
  CHECK_THAT(error.fix(), Catch::Contains(".obj, .ply, .stl, .vtk or .vtp"));
}

// Never an empty mesh: empty, garbled and cut-short files are errors naming the file.
// A binary STL of one triangle, written byte by byte as the format says
// (shorter than the 256 bytes VTK looks at to tell text from binary).
TEST_CASE("surface_mesh_reader: a binary STL of one triangle", "[io][unit]") {
  const std::string path = OutputPath("surface_mesh_reader_one_triangle.stl");
  {
    std::ofstream out(path, std::ios::binary);
    const std::string header(80, ' ');
    out.write(header.data(), header.size());
    const std::uint32_t count = 1;
    out.write(reinterpret_cast<const char*>(&count), sizeof count);
    const float facet[12] = {0, 0, 1, 0, 0, 0, 10, 0, 0, 0, 20, 0};  // normal, then three corners (mm)
    out.write(reinterpret_cast<const char*>(facet), sizeof facet);
    const std::uint16_t attributes = 0;
    out.write(reinterpret_cast<const char*>(&attributes), sizeof attributes);
  }
  const SurfaceMesh mesh = ReadSurfaceMesh(path, {1e-3, ""});
  REQUIRE(mesh.num_triangles() == 1);
  REQUIRE(mesh.num_vertices() == 3);
  CHECK(mesh.vertices_m.colwise().norm().maxCoeff() == Approx(0.020));
}

TEST_CASE("surface_mesh_reader: empty, garbled and cut-short files", "[io][unit]") {
  for (const std::string extension : {".obj", ".ply", ".stl", ".vtk", ".vtp"}) {
    for (const std::string& contents : {std::string(), std::string("this is not a mesh\n1 2 3\n")}) {
      const std::string path = OutputPath("surface_mesh_reader_bad" + extension);
      std::ofstream(path, std::ios::binary) << contents;
      INFO(path << " holding '" << contents << "'");
      CHECK(ReadError(path).where().rfind(path, 0) == 0);
    }
  }
  // Files cut to two thirds; a legacy VTK file of an unstructured grid.
  for (const std::string kind : {"binary.stl", "binary.vtk", "ascii.vtk", "appended.vtp"}) {
    const Written file = Write(kind, Octahedron(), "cut_short");
    std::filesystem::resize_file(file.name, std::filesystem::file_size(file.name) * 2 / 3);
    INFO(kind);
    const Error error = ReadError(file.name);
    CHECK(error.where() == file.name);
    if (kind == "binary.stl") {
      CHECK_THAT(error.problem(), Catch::Contains("a binary STL of 8 triangles has 484 bytes, this file 322"));
    }
  }
  const std::string grid = OutputPath("surface_mesh_reader_grid.vtk");
  std::ofstream(grid) << "# vtk DataFile Version 3.0\ngrid\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 0 double\n";
  CHECK_THAT(ReadError(grid).problem(), Catch::Contains("no POLYDATA"));
}

}  // namespace dg::io
