#include "io/h5_file.h"

#include <cstdio>
#include <filesystem>
#include <regex>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "sim/error.h"

namespace dg::io {
namespace {

std::string OutputPath(const std::string& name) {
  const std::string path = std::string(DG_BINARY_DIR) + "/" + name;
  std::filesystem::remove(path);
  return path;
}

// Values i * step + offset: distinct, and exact in every type they are written in.
template <typename T>
std::vector<T> Ramp(size_t count, double step, double offset) {
  std::vector<T> values(count);
  for (size_t i = 0; i < count; ++i) values[i] = static_cast<T>(i * step + offset);
  return values;
}

// What a shell command prints on stdout.
std::string CommandOutput(const std::string& command) {
  FILE* pipe = popen(command.c_str(), "r");
  REQUIRE(pipe != nullptr);
  std::string output;
  char buffer[4096];
  for (size_t n; (n = fread(buffer, 1, sizeof(buffer), pipe)) > 0;) output.append(buffer, n);
  REQUIRE(pclose(pipe) == 0);
  return output;
}

// The numbers of h5dump's DATA block, without its "(i,j):" position labels.
std::vector<double> DumpedValues(const std::string& dump) {
  const size_t begin = dump.find("DATA {"), end = dump.find('}', begin);
  REQUIRE(begin != std::string::npos);
  const std::string data = std::regex_replace(dump.substr(begin + 6, end - begin - 6),
                                              std::regex(R"(\(\d+(,\d+)*\):)"), " ");
  std::vector<double> values;
  const std::regex number(R"([-+]?\d+(\.\d+)?([eE][-+]?\d+)?)");
  for (std::sregex_iterator it(data.begin(), data.end(), number), last; it != last; ++it) {
    values.push_back(std::stod(it->str()));
  }
  return values;
}

Error ErrorOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const Error& error) {
    return error;
  }
  FAIL("no dg::Error thrown");
  throw;  // unreachable: FAIL throws
}

}  // namespace

// Arrays of every type and rank, strings, matrices and attributes of the root,
// of groups and of datasets read back unchanged, with their shapes, from nested groups.
TEST_CASE("h5_file: arrays, strings and attributes round trip", "[io][unit]") {
  const std::string path = OutputPath("h5_file_round_trip.h5");
  const std::vector<double> doubles = Ramp<double>(24, 0.125, -1.0);
  const std::vector<float> floats = Ramp<float>(5, 0.5, 0.25);
  const std::vector<std::int32_t> ints = Ramp<std::int32_t>(6, -7, 100);
  const std::vector<std::uint8_t> bytes = Ramp<std::uint8_t>(4, 60, 15);
  Eigen::Matrix4d T_C_S;
  T_C_S << 0, -1, 0, 0.01, 1, 0, 0, -0.02, 0, 0, 1, 0.06, 0, 0, 0, 1;
  const std::string scene = "camera:\n  fps: 30  # ünïcode\n";
  {
    H5Writer writer(path);
    writer.Write("/sim/deep/er/doubles", doubles.data(), {2, 3, 4});
    writer.Write("/floats", floats.data(), {5});
    writer.Write("/sim/ints", ints.data(), {3, 2});
    writer.Write("/images/bytes", bytes.data(), {2, 2});
    writer.WriteScalar("/period_s", 0.6875);
    writer.WriteMatrix("/T_C_S", T_C_S);
    writer.WriteString("/scene", scene);
    writer.CreateGroup("/empty/group");
    writer.WriteAttribute("/", "version", std::string("0.1.0"));
    writer.WriteAttribute("/", "threads", 2);
    writer.WriteAttribute("/", "threads", std::size_t{4});  // replaces the first
    writer.WriteAttribute("/sim", "dt_s", 2e-4);
    writer.WriteAttribute("/sim/ints", "unit", std::string("count"));
    writer.WriteAttribute("/empty/group", "negative", -3);
  }
  const H5Reader reader(path);
  H5Shape shape;
  REQUIRE(reader.Read<double>("/sim/deep/er/doubles", &shape) == doubles);
  REQUIRE(shape == H5Shape{2, 3, 4});
  REQUIRE(reader.Read<float>("/floats", &shape) == floats);
  REQUIRE(shape == H5Shape{5});
  REQUIRE(reader.Read<std::int32_t>("/sim/ints", &shape) == ints);
  REQUIRE(shape == H5Shape{3, 2});
  REQUIRE(reader.Read<std::uint8_t>("/images/bytes", &shape) == bytes);
  REQUIRE(shape == H5Shape{2, 2});
  // HDF5 converts on reading: the int32 dataset as doubles.
  REQUIRE(reader.Read<double>("/sim/ints") == std::vector<double>(ints.begin(), ints.end()));
  REQUIRE(reader.Shape("/period_s").empty());
  REQUIRE(reader.ReadScalar("/period_s") == 0.6875);
  REQUIRE(reader.Shape("/T_C_S") == H5Shape{4, 4});
  REQUIRE(reader.ReadMatrix("/T_C_S") == Eigen::MatrixXd(T_C_S));
  // Row-major as it prints: element (0, 3) is the fourth value.
  REQUIRE(reader.Read<double>("/T_C_S")[3] == 0.01);
  REQUIRE(reader.ReadString("/scene") == scene);
  REQUIRE(reader.ReadAttribute<std::string>("/", "version") == "0.1.0");
  REQUIRE(reader.ReadAttribute<std::int64_t>("/", "threads") == 4);
  REQUIRE(reader.ReadAttribute<double>("/sim", "dt_s") == 2e-4);
  REQUIRE(reader.ReadAttribute<std::string>("/sim/ints", "unit") == "count");
  REQUIRE(reader.ReadAttribute<std::int64_t>("/empty/group", "negative") == -3);
  REQUIRE(reader.ReadAttribute<double>("/empty/group", "negative") == -3.0);
  REQUIRE(reader.Has("/"));
  REQUIRE(reader.Has("/sim/deep/er"));
  REQUIRE(reader.Has("/empty/group"));
  REQUIRE_FALSE(reader.Has("/sim/deep/not"));
  REQUIRE_FALSE(reader.Has("/missing/parent/too"));
  REQUIRE(reader.HasAttribute("/sim", "dt_s"));
  REQUIRE_FALSE(reader.HasAttribute("/sim", "dt"));
}

// h5dump, an independent reader, sees the shapes, values, text and attributes written.
TEST_CASE("h5_file: h5dump reads what H5Writer wrote", "[io][unit]") {
  const std::string path = OutputPath("h5_file_h5dump.h5");
  const std::vector<double> doubles = {1.5, -2, 3.25, 0, 1e-3, 42};
  const std::vector<std::int32_t> ints = {7, -8, 9};
  {
    H5Writer writer(path);
    writer.Write("/sim/values_m", doubles.data(), {2, 3});
    writer.Write("/tracks/ids", ints.data(), {3});
    writer.WriteString("/scene", "fps: 30");
    writer.WriteAttribute("/sim", "threads", 2);
    writer.WriteAttribute("/", "machine", std::string("ci runner"));
  }
  const std::string values = CommandOutput("h5dump -d /sim/values_m " + path);
  REQUIRE_THAT(values, Catch::Contains("H5T_IEEE_F64LE") &&
                           Catch::Contains("DATASPACE  SIMPLE { ( 2, 3 ) / ( 2, 3 ) }"));
  REQUIRE(DumpedValues(values) == doubles);
  const std::string ids = CommandOutput("h5dump -d /tracks/ids " + path);
  REQUIRE_THAT(ids, Catch::Contains("H5T_STD_I32LE") &&
                        Catch::Contains("DATASPACE  SIMPLE { ( 3 ) / ( 3 ) }"));
  REQUIRE(DumpedValues(ids) == std::vector<double>{7, -8, 9});
  const std::string scene = CommandOutput("h5dump -d /scene " + path);
  REQUIRE_THAT(scene, Catch::Contains("DATASPACE  SCALAR") && Catch::Contains("\"fps: 30\""));
  const std::string threads = CommandOutput("h5dump -a /sim/threads " + path);
  REQUIRE_THAT(threads, Catch::Contains("H5T_STD_I64LE"));
  REQUIRE(DumpedValues(threads) == std::vector<double>{2});
  REQUIRE_THAT(CommandOutput("h5dump -a /machine " + path), Catch::Contains("\"ci runner\""));
}

// Mistakes are reported as dg::Error naming the file and the dataset or attribute.
TEST_CASE("h5_file: errors name the file and the dataset", "[io][unit]") {
  const std::string path = OutputPath("h5_file_errors.h5");
  const double value = 1.0;
  {
    H5Writer writer(path);
    writer.Write("/a/x", &value, {1});
    Error error = ErrorOf([&] { writer.Write("/a/x", &value, {1}); });
    REQUIRE(error.where() == path + ":/a/x");
    REQUIRE_THAT(error.problem(), Catch::Contains("already exists"));
    error = ErrorOf([&] { writer.WriteAttribute("/a/missing", "unit", std::string("m")); });
    REQUIRE_THAT(error.where(), Catch::Contains(path + ":/a/missing") && Catch::Contains("unit"));
    error = ErrorOf([&] { writer.Write("relative", &value, {1}); });
    REQUIRE(error.where() == path + ":relative");
    writer.WriteString("/text", "not a number");
  }
  const H5Reader reader(path);
  Error error = ErrorOf([&] { reader.Read<double>("/a/y"); });
  REQUIRE(error.where() == path + ":/a/y");
  REQUIRE_THAT(error.problem(), Catch::Contains("no such dataset"));
  error = ErrorOf([&] { reader.Read<double>("/text"); });
  REQUIRE(error.where() == path + ":/text");
  error = ErrorOf([&] { reader.ReadString("/a/x"); });
  REQUIRE(error.where() == path + ":/a/x");
  error = ErrorOf([&] { reader.ReadAttribute<double>("/a", "scale"); });
  REQUIRE_THAT(error.where(), Catch::Contains(path + ":/a") && Catch::Contains("scale"));
  const std::string missing = std::string(DG_BINARY_DIR) + "/no_such_file.h5";
  error = ErrorOf([&] { H5Reader{missing}; });
  REQUIRE(error.where() == missing);
}

}  // namespace dg::io
