#include "io/surface_mesh.h"

#include <filesystem>
#include <fstream>
#include <string>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>

#include "sim/error.h"

namespace dg::io {
namespace {

std::string OutputPath(const std::string& name) { return std::string(DG_BINARY_DIR) + "/" + name; }

std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// A square pyramid, 2 cm across and 1.5 cm high, its base split in two
// triangles: six triangles, five vertices, values with no short decimal form.
SurfaceMesh Pyramid(bool with_uvs, bool with_normals) {
  SurfaceMesh mesh;
  mesh.vertices_m.resize(3, 5);
  mesh.vertices_m << -0.01, 0.01, 0.01, -0.01, 0.0,  //
      -0.01, -0.01, 0.01, 0.01, 1.0 / 3e3,           //
      0.0, 0.0, 0.0, 0.0, 0.015;
  mesh.triangles.resize(3, 6);
  mesh.triangles << 0, 0, 0, 1, 2, 3,  //
      2, 3, 1, 2, 3, 0,                //
      1, 2, 4, 4, 4, 4;
  if (with_uvs) {
    mesh.uvs.resize(2, 5);
    mesh.uvs << 0, 1, 1, 0, 0.5,  //
        0, 0, 1, 1, 1.0 / 3;
  }
  if (with_normals) {
    mesh.normals = mesh.vertices_m.colwise() - Eigen::Vector3d(0, 0, 0.005);
    mesh.normals.colwise().normalize();
  }
  return mesh;
}

double Area(const SurfaceMesh& mesh) {
  double area = 0;
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    const Eigen::Vector3d a = mesh.vertices_m.col(mesh.triangles(0, t)),
                          b = mesh.vertices_m.col(mesh.triangles(1, t)),
                          c = mesh.vertices_m.col(mesh.triangles(2, t));
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  return area;
}

template <typename Read>
Error ReadError(Read read, const std::string& path) {
  try {
    read(path, SurfaceFileOptions{});
  } catch (const Error& error) {
    return error;
  }
  FAIL("no error reading " << path);
  throw;  // unreachable: FAIL throws
}

void RequireClose(const Eigen::MatrixXd& read, const Eigen::MatrixXd& written, double tolerance) {
  REQUIRE(read.rows() == written.rows());
  REQUIRE(read.cols() == written.cols());
  if (read.size() > 0) REQUIRE((read - written).cwiseAbs().maxCoeff() <= tolerance);
}

}  // namespace

// OBJ keeps every digit (shortest round-trip text); PLY keeps positions as
// doubles and normals and texture coordinates as floats.
TEST_CASE("surface_mesh: OBJ and PLY round trips", "[io][unit]") {
  for (bool with_uvs : {false, true}) {
    for (bool with_normals : {false, true}) {
      const SurfaceMesh mesh = Pyramid(with_uvs, with_normals);
      const std::string obj = OutputPath("surface_mesh_round_trip.obj");
      const std::string ply = OutputPath("surface_mesh_round_trip.ply");
      WriteObj(obj, mesh);
      WritePly(ply, mesh);
      for (const SurfaceMesh& read : {ReadObj(obj), ReadPly(ply)}) {
        REQUIRE(read.triangles == mesh.triangles);
        REQUIRE(read.vertices_m == mesh.vertices_m);
      }
      const SurfaceMesh from_obj = ReadObj(obj), from_ply = ReadPly(ply);
      REQUIRE(from_obj.uvs == mesh.uvs);
      REQUIRE(from_obj.normals == mesh.normals);
      RequireClose(from_ply.uvs, mesh.uvs, 1e-7);
      RequireClose(from_ply.normals, mesh.normals, 1e-7);
    }
  }
}

// A scale writes the file in other units (here millimetres) and reads it back to metres.
TEST_CASE("surface_mesh: files in millimetres", "[io][unit]") {
  const SurfaceMesh mesh = Pyramid(false, false);
  const SurfaceFileOptions millimetres{1e-3, ""};
  const std::string obj = OutputPath("surface_mesh_mm.obj");
  const std::string ply = OutputPath("surface_mesh_mm.ply");
  WriteObj(obj, mesh, millimetres);
  WritePly(ply, mesh, millimetres);
  REQUIRE_THAT(ReadText(obj), Catch::Contains("\nv -10 -10 0\n") &&
                                  Catch::Contains("\nv 0 0.3333333333333333 15\n"));
  RequireClose(ReadObj(obj).vertices_m * 1e-3, mesh.vertices_m, 1e-17);
  RequireClose(ReadObj(obj, millimetres).vertices_m, mesh.vertices_m, 1e-17);
  RequireClose(ReadPly(ply, millimetres).vertices_m, mesh.vertices_m, 1e-17);
}

// With a texture, the OBJ names a .mtl whose diffuse map is the image, and
// each face corner names its v, vt and vn.
TEST_CASE("surface_mesh: OBJ with a texture material", "[io][unit]") {
  const std::string obj = OutputPath("surface_mesh_textured.obj");
  WriteObj(obj, Pyramid(true, true), {1.0, "skin.png"});
  const std::string text = ReadText(obj);
  REQUIRE_THAT(text, Catch::Contains("mtllib surface_mesh_textured.mtl\nusemtl surface\n") &&
                         Catch::Contains("\nf 1/1/1 3/3/3 2/2/2\n"));
  const std::string mtl = ReadText(OutputPath("surface_mesh_textured.mtl"));
  REQUIRE_THAT(mtl,
               Catch::StartsWith("newmtl surface\n") && Catch::Contains("\nmap_Kd skin.png\n"));
}

// A hand-written OBJ: a quad with negative indices, a triangle that reuses a
// vertex with other texture coordinates (a seam), all index forms.
TEST_CASE("surface_mesh: OBJ quads, negative indices and seams", "[io][unit]") {
  const std::string path = OutputPath("surface_mesh_hand.obj");
  WriteText(path,
            "# a unit square in z = 0, and a seam at (1, 0, 0)\r\n"
            "o square\n"
            "v 0 0 0\nv 1 0 0\nv 1 1 0 1.0\nv 0 1 0\n"
            "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.5 0.25 0\n"
            "vn 0 0 1\n"
            "usemtl whatever\ns off\n"
            "f -4/-5/-1 -3/-4/-1 -2/-3/-1 -1/-2/-1\n"
            "f 2/5/1 3/3/1 4/4/1\n");
  const SurfaceMesh mesh = ReadObj(path);
  REQUIRE(mesh.num_vertices() == 5);
  Eigen::Matrix3Xi triangles(3, 3);
  triangles << 0, 0, 4,  //
      1, 2, 2,           //
      2, 3, 3;
  REQUIRE(mesh.triangles == triangles);
  REQUIRE(mesh.vertices_m.col(4) == Eigen::Vector3d(1, 0, 0));
  Eigen::Matrix2Xd uvs(2, 5);
  uvs << 0, 1, 1, 0, 0.5,  //
      0, 0, 1, 1, 0.25;
  REQUIRE(mesh.uvs == uvs);
  REQUIRE(mesh.normals == Eigen::Vector3d::UnitZ().replicate(1, 5));
  REQUIRE(Area(mesh) == Approx(1.5));

  // A pentagon of plain indices becomes a fan of three; without vt and vn on
  // every corner, the mesh has no uvs or normals.
  WriteText(path, "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\nvt 0 0\nf 1/1 2 3 4 5\n");
  const SurfaceMesh pentagon = ReadObj(path);
  REQUIRE(pentagon.num_triangles() == 3);
  REQUIRE(pentagon.uvs.cols() == 0);
  REQUIRE(pentagon.normals.cols() == 0);
  REQUIRE(Area(pentagon) == Approx(3.0));  // by the shoelace formula
}

// A malformed OBJ line is an error at its file:line.
TEST_CASE("surface_mesh: malformed OBJ lines name file:line", "[io][unit]") {
  const std::string path = OutputPath("surface_mesh_bad.obj");
  const std::string vertices = "v 0 0 0\nv 1 0 0\n\nv 0 1 0\n";
  for (const auto& [line, problem] : std::vector<std::pair<std::string, std::string>>{
           {"v 1 2", "needs 3 values"},
           {"v 1 2 x", "'x'"},
           {"f 1 2", "needs 3 values"},
           {"f 1 2 4", "refers to none of the 3"},
           {"f 1 2 -4", "refers to none of the 3"},
           {"f 1 2 0", "non-zero"},
           {"f 1/1 2 3", "vt index 1 refers to none of the 0"},
           {"f 1/x 2 3", "'x'"},
           {"f 1/1/1/1 2 3", "more than three"}}) {
    WriteText(path, vertices + line + "\n");
    const Error error = ReadError(ReadObj, path);
    INFO(line);
    REQUIRE(error.where() == path + ":5");
    REQUIRE_THAT(error.problem(), Catch::Contains(problem));
  }
}

// The binary PLY's header and size follow the PLY format exactly.
TEST_CASE("surface_mesh: binary PLY layout", "[io][unit]") {
  const std::string path = OutputPath("surface_mesh_layout.ply");
  WritePly(path, Pyramid(true, true));
  const std::string bytes = ReadText(path);
  const std::string header =
      "ply\nformat binary_little_endian 1.0\n"
      "comment dynaguide surface mesh; metres per unit: 1\n"
      "element vertex 5\nproperty double x\nproperty double y\nproperty double z\n"
      "property float nx\nproperty float ny\nproperty float nz\n"
      "property float s\nproperty float t\n"
      "element face 6\nproperty list uchar int vertex_indices\nend_header\n";
  REQUIRE(bytes.substr(0, header.size()) == header);
  REQUIRE(bytes.size() == header.size() + 5 * (3 * 8 + 3 * 4 + 2 * 4) + 6 * (1 + 3 * 4));
}

// A hand-written ASCII PLY with other element types and properties, integer
// and float types, u v texture names and a quad reads; its errors name file:line.
TEST_CASE("surface_mesh: ASCII PLY and its errors", "[io][unit]") {
  const std::string path = OutputPath("surface_mesh_ascii.ply");
  const std::string header =
      "ply\nformat ascii 1.0\ncomment made by hand\n"
      "element vertex 4\nproperty float x\nproperty float y\nproperty int z\n"
      "property uchar red\nproperty float u\nproperty float v\n"
      "element face 1\nproperty uint8 flags\nproperty list uchar uint vertex_index\n"
      "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n";
  WriteText(path, header +
                      "0 0 0 255 0 0\n2 0 0 0 1 0\n2 1 0 0 1 1\n0 1 0 0 0 1\n"
                      "7 4 0 1 2 3\n0 1\n");
  const SurfaceMesh mesh = ReadPly(path);
  REQUIRE(mesh.num_vertices() == 4);
  REQUIRE(mesh.num_triangles() == 2);
  REQUIRE(Area(mesh) == Approx(2.0));
  REQUIRE(mesh.uvs.col(2) == Eigen::Vector2d(1, 1));
  REQUIRE(mesh.normals.cols() == 0);

  // Line 22 is the face: index 4 is past the four vertices.
  WriteText(path, header +
                      "0 0 0 255 0 0\n2 0 0 0 1 0\n2 1 0 0 1 1\n0 1 0 0 0 1\n"
                      "7 4 0 1 2 4\n0 1\n");
  Error error = ReadError(ReadPly, path);
  REQUIRE(error.where() == path + ":22");
  REQUIRE_THAT(error.problem(), Catch::Contains("vertex index 4"));
  WriteText(path, "ply\nformat binary_big_endian 1.0\nend_header\n");
  REQUIRE(ReadError(ReadPly, path).where() == path + ":2");
  WriteText(path, "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n");
  REQUIRE(ReadError(ReadPly, path).where() == path + ":4");
}

// A binary PLY cut short is an error naming the element where it ends.
TEST_CASE("surface_mesh: truncated binary PLY", "[io][unit]") {
  const std::string path = OutputPath("surface_mesh_truncated.ply");
  WritePly(path, Pyramid(false, false));
  std::filesystem::resize_file(path, std::filesystem::file_size(path) - 5);
  const Error error = ReadError(ReadPly, path);
  REQUIRE(error.where() == path + ": element face 5");
  REQUIRE_THAT(error.problem(), Catch::Contains("ends"));
}

}  // namespace dg::io
