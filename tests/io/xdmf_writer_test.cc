#include "io/xdmf_writer.h"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <hdf5.h>

#include "sim/error.h"
#include "tests/io/two_tets.h"
#include "tests/io/xml_well_formed.h"
#include "tests/support/text_file.h"

namespace dg::io {
namespace {

// Displacement of step k: distinct values so a mixed-up step or node shows.
Eigen::Matrix3Xd Displacement(int k) {
  Eigen::Matrix3Xd u(3, 5);
  for (int a = 0; a < 5; ++a) u.col(a) << 1e-3 * k + a, 10.0 * a - k, -0.5 * k * a;
  return u;
}

using dg::testing::Matches;
using dg::testing::ReadText;

// The HDF5 file, opened read-only with the C API, closed at scope exit.
class H5File {
 public:
  explicit H5File(const std::string& path)
      : id_(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT)) {
    REQUIRE(id_ >= 0);
  }
  ~H5File() { H5Fclose(id_); }

  int RootIntAttribute(const char* name) const {
    const hid_t attribute = H5Aopen(id_, name, H5P_DEFAULT);
    REQUIRE(attribute >= 0);
    int value = -1;
    REQUIRE(H5Aread(attribute, H5T_NATIVE_INT, &value) >= 0);
    H5Aclose(attribute);
    return value;
  }

  // A dataset's shape and values (row-major), converted to double.
  std::vector<double> Read(const std::string& name, std::vector<hsize_t>* dims) const {
    const hid_t set = H5Dopen2(id_, name.c_str(), H5P_DEFAULT);
    REQUIRE(set >= 0);
    const hid_t space = H5Dget_space(set);
    dims->assign(H5Sget_simple_extent_ndims(space), 0);
    H5Sget_simple_extent_dims(space, dims->data(), nullptr);
    std::vector<double> values(H5Sget_simple_extent_npoints(space));
    REQUIRE(H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) >= 0);
    H5Sclose(space);
    H5Dclose(set);
    return values;
  }

 private:
  hid_t id_;
};

std::string OutputStem(const std::string& name) {
  const std::string stem = std::string(DG_BINARY_DIR) + "/" + name;
  std::filesystem::remove(stem + ".h5");
  std::filesystem::remove(stem + ".xmf");
  return stem;
}

}  // namespace

// A closed series reads back through the HDF5 C API: complete = 1, the step
// times, and at each step the displacement and fields at the dataset paths
// the well-formed .xmf names.
TEST_CASE("xdmf_writer: series reads back through HDF5 and the xmf", "[io][unit]") {
  const sim::TetMesh mesh = testing::TwoTets();
  const std::string stem = OutputStem("xdmf_writer_test");
  const std::vector<double> times = {0.0, 0.0125, 0.5};
  {
    XdmfTimeSeriesWriter writer(stem, mesh);
    for (int k = 0; k < 3; ++k) {
      MeshFields fields;
      fields.point_data.emplace_back("speed_m_per_s", Eigen::RowVectorXd::Constant(5, k));
      fields.cell_data.emplace_back("J", Eigen::RowVector2d(1.0 + k, 1.0 - k));
      fields.cell_data.emplace_back("stress_Pa", Eigen::MatrixXd::Constant(6, 2, k));
      fields.cell_data.emplace_back("F", Eigen::MatrixXd::Constant(9, 2, k));
      writer.Append(times[k], Displacement(k), fields);
    }
    REQUIRE(writer.num_steps() == 3);
    writer.Close(true);
  }

  const std::string xmf = ReadText(stem + ".xmf");
  REQUIRE(testing::XmlProblem(xmf) == "");
  REQUIRE_THAT(xmf, Catch::Contains("CollectionType=\"Temporal\"") &&
                        Catch::Contains("TopologyType=\"Tetrahedron\""));
  const std::vector<std::string> xmf_times = Matches(xmf, R"re(<Time Value="([^"]+)"/>)re");
  REQUIRE(xmf_times.size() == 3);
  for (int k = 0; k < 3; ++k) REQUIRE(std::stod(xmf_times[k]) == times[k]);
  const auto datasets = [&](const std::string& attribute) {
    return Matches(xmf,
                   "<Attribute Name=\"" + attribute +
                       R"re("[^>]*>\s*<DataItem[^>]*>xdmf_writer_test\.h5:([^<]+)</DataItem>)re");
  };
  const std::vector<std::string> displacement_sets = datasets("displacement_m");
  const std::vector<std::string> j_sets = datasets("J");
  REQUIRE(displacement_sets.size() == 3);
  REQUIRE(j_sets.size() == 3);

  H5File file(stem + ".h5");
  REQUIRE(file.RootIntAttribute("complete") == 1);
  std::vector<hsize_t> dims;
  REQUIRE(file.Read("/time_s", &dims) == times);
  const std::vector<std::string> geometry =
      Matches(xmf, R"re(<Geometry[^>]*>\s*<DataItem[^>]*>[^:<]+:([^<]+)<)re");
  REQUIRE(file.Read(geometry.at(0), &dims) ==
          std::vector<double>(mesh.X_m.data(), mesh.X_m.data() + 15));
  REQUIRE(dims == std::vector<hsize_t>{5, 3});
  const std::vector<std::string> topology =
      Matches(xmf, R"re(<Topology[^>]*>\s*<DataItem[^>]*>[^:<]+:([^<]+)<)re");
  REQUIRE(file.Read(topology.at(0), &dims) == std::vector<double>{0, 1, 2, 3, 1, 3, 2, 4});
  for (int k = 0; k < 3; ++k) {
    const Eigen::Matrix3Xd u = Displacement(k);
    REQUIRE(file.Read(displacement_sets[k], &dims) ==
            std::vector<double>(u.data(), u.data() + u.size()));
    REQUIRE(dims == std::vector<hsize_t>{5, 3});
    REQUIRE(file.Read(j_sets[k], &dims) == std::vector<double>{1.0 + k, 1.0 - k});
    REQUIRE(dims == std::vector<hsize_t>{2});
    REQUIRE(file.Read(datasets("stress_Pa").at(k), &dims) == std::vector<double>(12, k));
    REQUIRE(dims == std::vector<hsize_t>{2, 6});
  }
  REQUIRE_THAT(xmf, Catch::Contains("AttributeType=\"Tensor6\"") &&
                        Catch::Contains("AttributeType=\"Tensor\""));
}

namespace {

// The series that the next two tests leave: two steps (t = 0.1, 0.2 s) that
// read back through HDF5 and the .xmf, and complete = 0.
void RequireIncompleteTwoStepSeries(const std::string& stem) {
  H5File file(stem + ".h5");
  REQUIRE(file.RootIntAttribute("complete") == 0);
  std::vector<hsize_t> dims;
  REQUIRE(file.Read("/time_s", &dims) == std::vector<double>{0.1, 0.2});
  const Eigen::Matrix3Xd u = Displacement(2);
  REQUIRE(file.Read("/steps/000001/displacement_m", &dims) ==
          std::vector<double>(u.data(), u.data() + u.size()));
  const std::string xmf = ReadText(stem + ".xmf");
  REQUIRE(testing::XmlProblem(xmf) == "");
  REQUIRE(Matches(xmf, R"re(<Time Value="([^"]+)"/>)re").size() == 2);
}

}  // namespace

// A writer destroyed without Close() leaves complete = 0 and both files
// readable with the steps appended so far.
TEST_CASE("xdmf_writer: unclosed writer leaves a readable, incomplete series", "[io][unit]") {
  const std::string stem = OutputStem("xdmf_writer_test_unclosed");
  {
    XdmfTimeSeriesWriter writer(stem, testing::TwoTets());
    writer.Append(0.1, Displacement(1), {});
    writer.Append(0.2, Displacement(2), {});
  }
  RequireIncompleteTwoStepSeries(stem);
}

// A process that dies after two appends, without any destructor running,
// leaves both files readable with those two steps (and complete = 0).
TEST_CASE("xdmf_writer: a killed run leaves a readable series", "[io][unit]") {
  const std::string stem = OutputStem("xdmf_writer_test_killed");
  const pid_t child = fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    XdmfTimeSeriesWriter writer(stem, testing::TwoTets());
    writer.Append(0.1, Displacement(1), {});
    writer.Append(0.2, Displacement(2), {});
    _exit(0);
  }
  int status = 0;
  REQUIRE(waitpid(child, &status, 0) == child);
  REQUIRE(WIFEXITED(status));
  RequireIncompleteTwoStepSeries(stem);
}

// Before any step the .xmf already shows the mesh, and Close(false) marks it incomplete.
TEST_CASE("xdmf_writer: no steps still gives a readable mesh", "[io][unit]") {
  const std::string stem = OutputStem("xdmf_writer_test_empty");
  XdmfTimeSeriesWriter writer(stem, testing::TwoTets());
  const std::string xmf = ReadText(stem + ".xmf");
  REQUIRE(testing::XmlProblem(xmf) == "");
  REQUIRE_THAT(xmf, Catch::Contains("TopologyType=\"Tetrahedron\""));
  writer.Close(false);
  REQUIRE(H5File(stem + ".h5").RootIntAttribute("complete") == 0);
}

// Size mismatches, times that do not increase and an impossible path are refused.
TEST_CASE("xdmf_writer: bad input is refused", "[io][unit]") {
  REQUIRE_THROWS_WITH(XdmfTimeSeriesWriter("/nonexistent_dir/run", testing::TwoTets()),
                      Catch::Contains("directory does not exist"));
  XdmfTimeSeriesWriter writer(OutputStem("xdmf_writer_test_bad"), testing::TwoTets());
  REQUIRE_THROWS_WITH(writer.Append(0.0, Eigen::Matrix3Xd::Zero(3, 4), {}),
                      Catch::Contains("4 columns for 5 nodes"));
  MeshFields wrong_size;
  wrong_size.point_data.emplace_back("p_Pa", Eigen::RowVectorXd::Zero(2));
  REQUIRE_THROWS_WITH(writer.Append(0.0, Displacement(0), wrong_size), Catch::Contains("'p_Pa'"));
  writer.Append(1.0, Displacement(0), {});
  REQUIRE_THROWS_WITH(writer.Append(1.0, Displacement(0), {}),
                      Catch::Contains("not after the previous"));
  REQUIRE(writer.num_steps() == 1);
  writer.Close(true);
}

namespace {

// ParaView's XDMF reader (pvpython, Debian's `python3-paraview`), where
// installed: each time step's time and its points, as ParaView plays them.
// Empty without pvpython.
std::vector<std::vector<double>> ParaViewSteps(const std::string& xmf_path) {
  const char* pvpython = "/usr/bin/pvpython";
  if (!std::filesystem::exists(pvpython)) return {};
  const std::string script = xmf_path + ".py";
  std::ofstream(script) << "from paraview.simple import XDMFReader, servermanager\n"
                           "r = XDMFReader(FileNames=['"
                        << xmf_path
                        << "'])\n"
                           "r.UpdatePipelineInformation()\n"
                           "for t in r.TimestepValues:\n"
                           "    r.UpdatePipeline(t)\n"
                           "    data = servermanager.Fetch(r)\n"
                           "    block = data.GetBlock(0) if data.IsA('vtkMultiBlockDataSet') else data\n"
                           "    points = block.GetPoints()\n"
                           "    values = [t] + [points.GetPoint(i)[j] for i in range(points.GetNumberOfPoints()) "
                           "for j in range(3)]\n"
                           "    print('step', ' '.join(repr(v) for v in values))\n";
  const std::string command = std::string(pvpython) + " --force-offscreen-rendering " + script + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  REQUIRE(pipe);
  std::string output;
  char buffer[4096];
  while (fgets(buffer, sizeof buffer, pipe)) output += buffer;
  REQUIRE(pclose(pipe) == 0);
  INFO(output);
  std::vector<std::vector<double>> steps;
  std::istringstream lines(output);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("step ", 0) != 0) continue;
    std::istringstream values(line.substr(5));
    steps.emplace_back(std::istream_iterator<double>(values), std::istream_iterator<double>());
  }
  REQUIRE_FALSE(steps.empty());
  return steps;
}

}  // namespace

// With deformed_geometry each step's grid takes X + u as its geometry, so
// that ParaView plays the motion as it opens the file; with h5_file_name the
// data goes to that file, which the .xmf names. Read back through HDF5 and,
// where installed, ParaView's XDMF reader (its points at each time step).
TEST_CASE("xdmf_writer: deformed geometry per step, in a data file of its own name", "[io][unit]") {
  const sim::TetMesh mesh = testing::TwoTets();
  const std::string stem = OutputStem("xdmf_writer_test_deformed");
  const std::string data = std::string(DG_BINARY_DIR) + "/xdmf_writer_test_deformed_data.h5";
  std::filesystem::remove(data);
  XdmfSeriesOptions options;
  options.deformed_geometry = true;
  options.h5_file_name = "xdmf_writer_test_deformed_data.h5";
  {
    XdmfTimeSeriesWriter writer(stem, mesh, options);
    REQUIRE(writer.h5_path() == data);
    for (int k = 0; k < 3; ++k) writer.Append(0.25 * k, Displacement(k), {});
    writer.Close(true);
  }
  REQUIRE_FALSE(std::filesystem::exists(stem + ".h5"));
  const std::string xmf = ReadText(stem + ".xmf");
  REQUIRE(testing::XmlProblem(xmf) == "");
  const std::vector<std::string> geometry =
      Matches(xmf, R"re(<Geometry[^>]*>\s*<DataItem[^>]*>([^<]+)</DataItem>)re");
  REQUIRE(geometry.size() == 3);
  H5File file(data);
  for (int k = 0; k < 3; ++k) {
    REQUIRE(geometry[k] == "xdmf_writer_test_deformed_data.h5:/steps/00000" + std::to_string(k) + "/geometry_m");
    const Eigen::Matrix3Xd deformed = mesh.X_m + Displacement(k);
    std::vector<hsize_t> dims;
    REQUIRE(file.Read(geometry[k].substr(geometry[k].find(':') + 1), &dims) ==
            std::vector<double>(deformed.data(), deformed.data() + deformed.size()));
  }

  const std::vector<std::vector<double>> paraview = ParaViewSteps(stem + ".xmf");
  if (paraview.empty()) {
    WARN("pvpython (Debian's python3-paraview) is not installed: the series was not read through ParaView");
  } else {
    REQUIRE(paraview.size() == 3);
    for (int k = 0; k < 3; ++k) {
      REQUIRE(paraview[k].size() == 1 + 15);
      CHECK(paraview[k][0] == 0.25 * k);
      // ParaView's XDMF reader hands the points over as float.
      const Eigen::Matrix3Xd deformed = mesh.X_m + Displacement(k);
      for (int i = 0; i < 15; ++i) CHECK(paraview[k][1 + i] == Approx(deformed.data()[i]).epsilon(1e-7).margin(1e-7));
    }
  }

  options.h5_file_name = "sub/data.h5";
  REQUIRE_THROWS_WITH(XdmfTimeSeriesWriter(stem, mesh, options), Catch::Contains("is a path"));
}

// Without xmf_every_step the .xmf is rewritten at a sixteenth's growth: while
// the series grows it lists a prefix of the steps (never one the .h5 lacks),
// at most a sixteenth behind, in a number of rewrites that grows with the
// logarithm of the steps; Close() lists them all.
TEST_CASE("xdmf_writer: a long series rewrites its .xmf at a sixteenth's growth", "[io][unit]") {
  const std::string stem = OutputStem("xdmf_writer_test_long");
  XdmfSeriesOptions options;
  options.xmf_every_step = false;
  XdmfTimeSeriesWriter writer(stem, testing::TwoTets(), options);
  const int steps = 200;
  int rewrites = 0;
  size_t listed = 0;
  for (int k = 0; k < steps; ++k) {
    writer.Append(0.01 * k, Displacement(k), {});
    const size_t now = Matches(ReadText(stem + ".xmf"), R"re(<Time Value="([^"]+)"/>)re").size();
    REQUIRE(now <= size_t(k + 1));
    REQUIRE(now + std::max(1, (k + 1) / 16) > size_t(k + 1));
    if (now != listed) ++rewrites;
    listed = now;
  }
  // Every step up to 31, then at a sixteenth's growth (rounded down): about
  // 31 + ln(200 / 32) / ln(17 / 16) = 61; 63 with the rounding. Every step: 200.
  CHECK(rewrites == 63);
  writer.Close(false);
  REQUIRE(Matches(ReadText(stem + ".xmf"), R"re(<Time Value="([^"]+)"/>)re").size() == size_t(steps));
  REQUIRE(H5File(stem + ".h5").RootIntAttribute("complete") == 0);
}

// The test's XML check itself accepts well-formed text and names what is wrong otherwise.
TEST_CASE("xml check: rejects malformed XML", "[io][unit]") {
  REQUIRE(testing::XmlProblem("<?xml version=\"1.0\"?>\n<a x=\"1\"><b/>t &amp; u</a>\n") == "");
  REQUIRE_THAT(testing::XmlProblem("<a><b></a></b>"), Catch::Contains("does not match"));
  REQUIRE_THAT(testing::XmlProblem("<a x=1/>"), Catch::Contains("malformed attribute"));
  REQUIRE_THAT(testing::XmlProblem("<a>"), Catch::Contains("unclosed"));
  REQUIRE_THAT(testing::XmlProblem("<a/><b/>"), Catch::Contains("more than one root"));
  REQUIRE_THAT(testing::XmlProblem("<a>x & y</a>"), Catch::Contains("bare &"));
}

}  // namespace dg::io
