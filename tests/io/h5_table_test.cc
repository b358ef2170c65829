#include "io/h5_table.h"

#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <hdf5.h>

#include "sim/error.h"
#include "tests/support/temporary_folder.h"

namespace dg::io {
namespace {

// One dataset as the plain HDF5 C API sees it, independently of io/.
struct Dataset {
  std::vector<hsize_t> dims, max_dims, chunk;
  bool deflate = false;
  std::vector<double> values;  // converted by HDF5 from the stored type
  H5T_class_t type_class = H5T_NO_CLASS;
  size_t type_size = 0;
};

Dataset ReadDataset(const std::string& path, const std::string& name) {
  Dataset out;
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  const hid_t dataset = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
  REQUIRE(dataset >= 0);
  const hid_t space = H5Dget_space(dataset);
  const int rank = H5Sget_simple_extent_ndims(space);
  out.dims.resize(rank);
  out.max_dims.resize(rank);
  H5Sget_simple_extent_dims(space, out.dims.data(), out.max_dims.data());
  const hid_t type = H5Dget_type(dataset);
  out.type_class = H5Tget_class(type);
  out.type_size = H5Tget_size(type);
  const hid_t properties = H5Dget_create_plist(dataset);
  if (H5Pget_layout(properties) == H5D_CHUNKED) {
    out.chunk.resize(rank);
    H5Pget_chunk(properties, rank, out.chunk.data());
  }
  for (int f = 0; f < H5Pget_nfilters(properties); ++f) {
    unsigned flags = 0;
    size_t n = 0;
    if (H5Pget_filter2(properties, f, &flags, &n, nullptr, 0, nullptr, nullptr) == H5Z_FILTER_DEFLATE) {
      out.deflate = true;
    }
  }
  hsize_t count = 1;
  for (hsize_t d : out.dims) count *= d;
  out.values.resize(count);
  if (count > 0) REQUIRE(H5Dread(dataset, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.values.data()) >= 0);
  H5Pclose(properties);
  H5Tclose(type);
  H5Sclose(space);
  H5Dclose(dataset);
  H5Fclose(file);
  return out;
}

// Above 2^53, where doubles no longer hold every integer: only a true int64 column keeps kBigFrame + i.
constexpr std::int64_t kBigFrame = std::int64_t{1} << 60;

std::vector<double> Ramp(size_t count, double offset) {
  std::vector<double> values(count);
  for (size_t i = 0; i < count; ++i) values[i] = offset + static_cast<double>(i);
  return values;
}

// Rows appended singly and in blocks that straddle chunk boundaries read back
// through the plain C API in order, with each column's type, shape, unlimited
// length, chunking and compression, beside the writer's own datasets.
TEST_CASE("h5 table: rows and blocks read back through the HDF5 C API", "[io][unit]") {
  const testing::TemporaryFolder folder("dg_h5_table_test");
  const std::string path = folder.File("h5_table_roundtrip.h5");
  {
    H5Writer file(path);
    file.WriteString("/scene", "text before the table");
    H5Table table(file, "/run/timings",
                  {{"frame", H5Type::kInt64}, {"stage", H5Type::kInt32}, {"kind", H5Type::kUInt8, 1, "0 a, 1 b, 2 c"},
                   {"xyz_m", H5Type::kDouble, 3}, {"quality", H5Type::kFloat}},
                  {.chunk_rows = 4, .deflate_level = 6});
    // Row i: frame kBigFrame + i, stage 2i,
    // kind i % 3, xyz (i, i + 0.25, i + 0.5), quality i / 4.
    for (std::int64_t i = 0; i < 3; ++i) {
      table.AppendRow({kBigFrame + i, static_cast<std::int32_t>(2 * i),
                       static_cast<std::uint8_t>(i % 3), std::vector<double>{i + 0.0, i + 0.25, i + 0.5},
                       static_cast<float>(i) / 4});
    }
    std::vector<std::int64_t> frames;
    std::vector<std::int32_t> stages;
    std::vector<std::uint8_t> kinds;
    std::vector<double> xyz;
    std::vector<float> quality;
    for (std::int64_t i = 3; i < 14; ++i) {
      frames.push_back(kBigFrame + i);
      stages.push_back(static_cast<std::int32_t>(2 * i));
      kinds.push_back(static_cast<std::uint8_t>(i % 3));
      xyz.insert(xyz.end(), {i + 0.0, i + 0.25, i + 0.5});
      quality.push_back(static_cast<float>(i) / 4);
    }
    table.Append(frames.size(), {frames, stages, kinds, xyz, quality});
    CHECK(table.rows() == 14);
    file.WriteAttribute("/", "complete", 1);
  }

  const Dataset frame = ReadDataset(path, "/run/timings/frame");
  CHECK(frame.dims == std::vector<hsize_t>{14});
  CHECK(frame.max_dims == std::vector<hsize_t>{H5S_UNLIMITED});
  CHECK(frame.chunk == std::vector<hsize_t>{4});
  CHECK(frame.deflate);
  CHECK(frame.type_class == H5T_INTEGER);
  CHECK(frame.type_size == 8);
  {
    const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    const hid_t dataset = H5Dopen2(file, "/run/timings/frame", H5P_DEFAULT);
    std::vector<std::int64_t> values(14);
    REQUIRE(H5Dread(dataset, H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) >= 0);
    for (std::int64_t i = 0; i < 14; ++i) CHECK(values[i] == kBigFrame + i);
    H5Dclose(dataset);
    H5Fclose(file);
  }
  const Dataset stage = ReadDataset(path, "/run/timings/stage");
  CHECK(stage.type_size == 4);
  CHECK(stage.type_class == H5T_INTEGER);
  const Dataset kind = ReadDataset(path, "/run/timings/kind");
  CHECK(kind.type_size == 1);
  const Dataset xyz = ReadDataset(path, "/run/timings/xyz_m");
  CHECK(xyz.dims == std::vector<hsize_t>{14, 3});
  CHECK(xyz.chunk == std::vector<hsize_t>{4, 3});
  CHECK(xyz.type_class == H5T_FLOAT);
  CHECK(xyz.type_size == 8);
  const Dataset quality = ReadDataset(path, "/run/timings/quality");
  CHECK(quality.type_class == H5T_FLOAT);
  CHECK(quality.type_size == 4);
  for (size_t i = 0; i < 14; ++i) {
    CHECK(stage.values[i] == 2.0 * i);
    CHECK(kind.values[i] == i % 3);
    CHECK(xyz.values[3 * i] == i);
    CHECK(xyz.values[3 * i + 1] == i + 0.25);
    CHECK(xyz.values[3 * i + 2] == i + 0.5);
    CHECK(quality.values[i] == i / 4.0);
  }
  H5Reader reader(path);
  CHECK(reader.ReadString("/scene") == "text before the table");
  CHECK(reader.ReadAttribute<std::int64_t>("/", "complete") == 1);
  CHECK(reader.ReadAttribute<std::string>("/run/timings/kind", "values") == "0 a, 1 b, 2 c");
}

// A process that dies without closing anything leaves a readable file holding
// every row appended before its last Flush, and none of the rows after it.
TEST_CASE("h5 table: a process killed after Flush leaves the flushed rows readable", "[io][unit]") {
  const testing::TemporaryFolder folder("dg_h5_table_test");
  const std::string path = folder.File("h5_table_killed.h5");
  const pid_t child = fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    auto* file = new H5Writer(path);  // never deleted: the process dies with the file open
    file->WriteAttribute("/", "complete", 0);
    auto* table = new H5Table(*file, "/rows", {{"i", H5Type::kInt32}}, {.chunk_rows = 64});
    for (std::int32_t i = 0; i < 100; ++i) table->AppendRow({i});  // one chunk written, 36 rows buffered
    table->Flush();
    for (std::int32_t i = 100; i < 110; ++i) table->AppendRow({i});  // buffered, never flushed
    _exit(0);
  }
  int status = 0;
  REQUIRE(waitpid(child, &status, 0) == child);
  REQUIRE(WIFEXITED(status));
  const Dataset rows = ReadDataset(path, "/rows/i");
  CHECK(rows.values == Ramp(100, 0));
  CHECK(H5Reader(path).ReadAttribute<std::int64_t>("/", "complete") == 0);
}

// Values of another type or count than a column's, or a malformed column
// list, are errors naming the column; a rejected block appends nothing.
TEST_CASE("h5 table: mismatched values and bad columns are errors", "[io][unit]") {
  const testing::TemporaryFolder folder("dg_h5_table_test");
  const std::string path = folder.File("h5_table_errors.h5");
  H5Writer file(path);
  H5Table table(file, "/t", {{"frame", H5Type::kInt64}, {"xy", H5Type::kDouble, 2}});
  CHECK_THROWS_WITH(table.AppendRow({std::int32_t{1}, std::vector<double>{1, 2}}),
                    Catch::Contains("column 'frame' takes 1 int64 values") && Catch::Contains("got 1 int32"));
  CHECK_THROWS_WITH(table.AppendRow({std::int64_t{1}, 2.0}), Catch::Contains("column 'xy' takes 2 double"));
  CHECK_THROWS_WITH(table.AppendRow({std::int64_t{1}}), Catch::Contains("appended 1 columns to a table of 2"));
  CHECK(table.rows() == 0);
  CHECK_THROWS_WITH(H5Table(file, "/t", {{"a", H5Type::kFloat}}), Catch::Contains("already exists"));
  CHECK_THROWS_WITH(H5Table(file, "/u", {{"a", H5Type::kFloat}, {"a", H5Type::kInt32}}),
                    Catch::Contains("column 'a'"));
  CHECK_THROWS_WITH(H5Table(file, "/v", {{"a", H5Type::kFloat, 0}}), Catch::Contains("width 0"));
  CHECK_THROWS_WITH(H5Table(file, "/w", {{"a", H5Type::kFloat}}, {.chunk_rows = 0}),
                    Catch::Contains("chunk_rows"));
}

}  // namespace
}  // namespace dg::io
