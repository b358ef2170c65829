#include "io/vtu_writer.h"

#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "sim/error.h"
#include "tests/io/two_tets.h"
#include "tests/io/xml_well_formed.h"

namespace dg::io {
namespace {

// What the test's own parse of a .vtu found: each DataArray's attributes, the
// section it sits in, and its appended bytes.
struct ParsedArray {
  std::map<std::string, std::string> attributes;
  std::string section;
  std::string bytes;
};

struct ParsedVtu {
  std::string xml;  // the file without its raw appended bytes
  std::map<std::string, std::string> piece;
  std::map<std::string, ParsedArray> arrays;
};

std::map<std::string, std::string> Attributes(const std::string& tag) {
  std::map<std::string, std::string> attributes;
  const std::regex attribute(R"re((\w+)="([^"]*)")re");
  for (std::sregex_iterator it(tag.begin(), tag.end(), attribute), end; it != end; ++it) {
    attributes[(*it)[1]] = (*it)[2];
  }
  return attributes;
}

// Reads a .vtu with raw appended data: the XML up to the '_' that starts the
// data, each block as a UInt64 byte count then the bytes, then the closing tags.
ParsedVtu ParseVtu(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const std::string file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t appended = file.find("<AppendedData encoding=\"raw\">");
  REQUIRE(appended != std::string::npos);
  const size_t data = file.find('_', appended) + 1;
  const std::string head = file.substr(0, data - 1);
  ParsedVtu vtu;
  const std::regex piece(R"(<Piece[^>]*>)"), array(R"(<DataArray[^>]*>)");
  std::smatch match;
  REQUIRE(std::regex_search(head, match, piece));
  vtu.piece = Attributes(match.str());
  size_t data_end = data;
  for (std::sregex_iterator it(head.begin(), head.end(), array), end; it != end; ++it) {
    ParsedArray parsed;
    parsed.attributes = Attributes(it->str());
    for (const char* section : {"PointData", "CellData", "Points", "Cells"}) {
      const size_t open = head.find(std::string("<") + section + ">");
      const size_t close = head.find(std::string("</") + section + ">");
      const size_t at = static_cast<size_t>(it->position());
      if (open != std::string::npos && open < at && at < close) parsed.section = section;
    }
    const size_t block = data + std::stoull(parsed.attributes.at("offset"));
    std::uint64_t size = 0;
    std::memcpy(&size, file.data() + block, sizeof(size));
    parsed.bytes = file.substr(block + sizeof(size), size);
    REQUIRE(parsed.bytes.size() == size);
    data_end = std::max<size_t>(data_end, block + sizeof(size) + size);
    vtu.arrays[parsed.attributes.at("Name")] = parsed;
  }
  vtu.xml = head + file.substr(data_end);
  return vtu;
}

template <typename T>
std::vector<T> Values(const ParsedArray& array) {
  std::vector<T> values(array.bytes.size() / sizeof(T));
  std::memcpy(values.data(), array.bytes.data(), values.size() * sizeof(T));
  return values;
}

std::vector<double> ColumnMajor(const Eigen::MatrixXd& m) {
  return {m.data(), m.data() + m.size()};
}

}  // namespace

// A written .vtu is well-formed XML around its raw data, and an independent
// parse reads back the points, cells, displacement and fields exactly.
TEST_CASE("vtu_writer: round trip through an independent parse", "[io][unit]") {
  const sim::TetMesh mesh = testing::TwoTets();
  Eigen::Matrix3Xd displacement = Eigen::Matrix3Xd::Random(3, 5) * 1e-3;
  MeshFields fields;
  fields.point_data.emplace_back("temperature_K", Eigen::RowVectorXd::LinSpaced(5, 300, 304));
  fields.cell_data.emplace_back("J", Eigen::RowVector2d(0.99, 1.01));
  fields.cell_data.emplace_back("stress_Pa", Eigen::MatrixXd::Random(9, 2));
  const std::string path = std::string(DG_BINARY_DIR) + "/vtu_writer_test.vtu";
  WriteVtu(path, mesh, &displacement, fields);

  const ParsedVtu vtu = ParseVtu(path);
  REQUIRE(testing::XmlProblem(vtu.xml) == "");
  REQUIRE_THAT(vtu.xml, Catch::Contains("type=\"UnstructuredGrid\"") &&
                            Catch::Contains("byte_order=\"LittleEndian\"") &&
                            Catch::Contains("header_type=\"UInt64\""));
  REQUIRE(vtu.piece.at("NumberOfPoints") == "5");
  REQUIRE(vtu.piece.at("NumberOfCells") == "2");
  const auto& arrays = vtu.arrays;
  REQUIRE(arrays.size() == 8);

  const auto check_doubles = [&](const std::string& name, const char* section,
                                 const Eigen::MatrixXd& truth) {
    INFO(name);
    const ParsedArray& array = arrays.at(name);
    REQUIRE(array.section == section);
    REQUIRE(array.attributes.at("type") == "Float64");
    REQUIRE(array.attributes.at("NumberOfComponents") == std::to_string(truth.rows()));
    REQUIRE(Values<double>(array) == ColumnMajor(truth));
  };
  check_doubles("Points", "Points", mesh.X_m);
  check_doubles("displacement_m", "PointData", displacement);
  check_doubles("temperature_K", "PointData", fields.point_data[0].second);
  check_doubles("J", "CellData", fields.cell_data[0].second);
  check_doubles("stress_Pa", "CellData", fields.cell_data[1].second);

  REQUIRE(arrays.at("connectivity").section == "Cells");
  REQUIRE(Values<std::int64_t>(arrays.at("connectivity")) ==
          std::vector<std::int64_t>{0, 1, 2, 3, 1, 3, 2, 4});
  REQUIRE(Values<std::int64_t>(arrays.at("offsets")) == std::vector<std::int64_t>{4, 8});
  REQUIRE(Values<std::uint8_t>(arrays.at("types")) ==
          std::vector<std::uint8_t>{10, 10});  // VTK_TETRA
}

// Without a displacement no displacement array is written.
TEST_CASE("vtu_writer: displacement is optional", "[io][unit]") {
  const std::string path = std::string(DG_BINARY_DIR) + "/vtu_writer_test_plain.vtu";
  WriteVtu(path, testing::TwoTets(), nullptr, {});
  const ParsedVtu vtu = ParseVtu(path);
  REQUIRE(testing::XmlProblem(vtu.xml) == "");
  REQUIRE(vtu.arrays.count("displacement_m") == 0);
  REQUIRE(vtu.arrays.size() == 4);
}

// Wrongly sized or misnamed fields and an unwritable path are refused by name.
TEST_CASE("vtu_writer: bad input is refused", "[io][unit]") {
  const sim::TetMesh mesh = testing::TwoTets();
  const std::string path = std::string(DG_BINARY_DIR) + "/vtu_writer_test_bad.vtu";
  MeshFields wrong_size;
  wrong_size.cell_data.emplace_back("J", Eigen::RowVector3d(1, 1, 1));
  REQUIRE_THROWS_WITH(WriteVtu(path, mesh, nullptr, wrong_size),
                      Catch::Contains("'J'") && Catch::Contains("expected components x 2"));
  MeshFields bad_name;
  bad_name.point_data.emplace_back("a<b", Eigen::RowVectorXd::Zero(5));
  REQUIRE_THROWS_WITH(WriteVtu(path, mesh, nullptr, bad_name), Catch::Contains("'a<b'"));
  MeshFields reserved;
  reserved.point_data.emplace_back("displacement_m", Eigen::MatrixXd::Zero(3, 5));
  REQUIRE_THROWS_AS(WriteVtu(path, mesh, nullptr, reserved), Error);
  const Eigen::Matrix3Xd short_displacement = Eigen::Matrix3Xd::Zero(3, 4);
  REQUIRE_THROWS_WITH(WriteVtu(path, mesh, &short_displacement, {}),
                      Catch::Contains("4 columns for 5 nodes"));
  REQUIRE_THROWS_WITH(WriteVtu("/nonexistent_dir/x.vtu", mesh, nullptr, {}),
                      Catch::Contains("cannot create"));
}

}  // namespace dg::io
