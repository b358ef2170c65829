#include "io/vtu_writer.h"

#include <bit>
#include <cstdint>
#include <fstream>
#include <functional>
#include <sstream>
#include <vector>

#include "sim/error.h"

namespace dg::io {
namespace {

// Appended blocks are memory images of the arrays, declared little-endian.
static_assert(std::endian::native == std::endian::little,
              "the .vtu writer assumes a little-endian host");

constexpr std::uint8_t kVtkTetra = 10;

// One DataArray: its XML description and the bytes of its appended block.
struct Array {
  std::string name;
  const char* type;  // VTK type name
  Eigen::Index components;
  const void* data;
  std::uint64_t bytes;
};

template <typename Derived>
Array Float64Array(const std::string& name, const Eigen::PlainObjectBase<Derived>& values) {
  return {name, "Float64", values.rows(), values.data(), sizeof(double) * values.size()};
}

// Writes `arrays` as appended DataArrays under the XML element `parent`;
// `offset` is the running position in the appended data.
void WriteArrays(const char* parent, const std::vector<Array>& arrays, std::uint64_t* offset,
                 std::ostream& xml) {
  xml << "      <" << parent << ">\n";
  for (const Array& array : arrays) {
    xml << "        <DataArray type=\"" << array.type << "\" Name=\"" << array.name
        << "\" NumberOfComponents=\"" << array.components << "\" format=\"appended\" offset=\""
        << *offset << "\"/>\n";
    *offset += sizeof(std::uint64_t) + array.bytes;
  }
  xml << "      </" << parent << ">\n";
}

void WriteBlocks(const std::vector<Array>& arrays, std::ostream& out) {
  for (const Array& array : arrays) {
    out.write(reinterpret_cast<const char*>(&array.bytes), sizeof(array.bytes));
    out.write(static_cast<const char*>(array.data), static_cast<std::streamsize>(array.bytes));
  }
}

}  // namespace

void WriteVtu(const std::string& path, const sim::TetMesh& mesh,
              const Eigen::Matrix3Xd* displacement_m, const MeshFields& fields) {
  CheckMeshFields(fields, mesh.num_nodes(), mesh.num_tets(), path);
  if (displacement_m && displacement_m->cols() != mesh.num_nodes()) {
    throw Error("displacement has " + std::to_string(displacement_m->cols()) + " columns for " +
                    std::to_string(mesh.num_nodes()) + " nodes",
                path, "pass one displacement column per node of the mesh");
  }
  // VTK wants 64-bit connectivity with these headers, and each cell's end offset.
  const Eigen::Matrix<std::int64_t, 4, Eigen::Dynamic> connectivity =
      mesh.tets.cast<std::int64_t>();
  std::vector<std::int64_t> offsets(mesh.num_tets());
  for (int e = 0; e < mesh.num_tets(); ++e) offsets[e] = 4 * (e + 1);
  const std::vector<std::uint8_t> types(mesh.num_tets(), kVtkTetra);

  std::vector<Array> point_data, cell_data;
  if (displacement_m) point_data.push_back(Float64Array(kDisplacementName, *displacement_m));
  for (const auto& [name, values] : fields.point_data) {
    point_data.push_back(Float64Array(name, values));
  }
  for (const auto& [name, values] : fields.cell_data) {
    cell_data.push_back(Float64Array(name, values));
  }
  const std::vector<Array> points = {Float64Array("Points", mesh.X_m)};
  const std::vector<Array> cells = {
      {"connectivity", "Int64", 1, connectivity.data(), sizeof(std::int64_t) * connectivity.size()},
      {"offsets", "Int64", 1, offsets.data(), sizeof(std::int64_t) * offsets.size()},
      {"types", "UInt8", 1, types.data(), types.size()}};

  std::ostringstream xml;
  std::uint64_t offset = 0;
  xml << "<?xml version=\"1.0\"?>\n"
      << "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\">\n"
      << "  <UnstructuredGrid>\n"
      << "    <Piece NumberOfPoints=\"" << mesh.num_nodes() << "\" NumberOfCells=\""
      << mesh.num_tets() << "\">\n";
  WriteArrays("PointData", point_data, &offset, xml);
  WriteArrays("CellData", cell_data, &offset, xml);
  WriteArrays("Points", points, &offset, xml);
  WriteArrays("Cells", cells, &offset, xml);
  xml << "    </Piece>\n  </UnstructuredGrid>\n  <AppendedData encoding=\"raw\">\n   _";

  std::ofstream out(path, std::ios::binary);
  if (!out) {
    throw Error("cannot create .vtu file", path, "check that the directory exists and is writable");
  }
  out << xml.str();
  // Blocks in the order WriteArrays gave them their offsets.
  for (const auto& arrays :
       {std::cref(point_data), std::cref(cell_data), std::cref(points), std::cref(cells)}) {
    WriteBlocks(arrays, out);
  }
  out << "\n  </AppendedData>\n</VTKFile>\n";
  out.close();
  if (!out) {
    throw Error("writing the .vtu file failed", path, "check free disk space and permissions");
  }
}

}  // namespace dg::io
