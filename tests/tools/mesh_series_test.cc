// The mesh series of `dynaguide run` (mesh_series.xmf + .h5) and the
// phantom's scan.xmf, read back through the HDF5 C API and, where ParaView is
// installed, through its XDMF reader: the series agrees with the run log, an
// independent record of the same run (its sampled nodes, times and tied-node
// counts), and the phantom's series with scan.h5's motion.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <regex>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "pipeline/run_scene.h"
#include "tests/io/xml_well_formed.h"
#include "tests/support/h5_plain.h"
#include "tests/support/text_file.h"
#include "tests/support/tiny_phantom.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;
using dg::testing::Matches;
using dg::testing::ReadText;
using dg::testing::TinyPhantomDir;
using namespace dg::testing::h5_plain;

// A dataset's dimensions, through the plain C API.
std::vector<hsize_t> Dims(hid_t file, const std::string& dataset) {
  const hid_t set = H5Dopen2(file, dataset.c_str(), H5P_DEFAULT);
  REQUIRE(set >= 0);
  const hid_t space = H5Dget_space(set);
  std::vector<hsize_t> dims(static_cast<size_t>(H5Sget_simple_extent_ndims(space)));
  H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  H5Sclose(space);
  H5Dclose(set);
  return dims;
}

bool Exists(hid_t file, const std::string& path) {
  // Each link on the way must exist before the next is looked up.
  for (size_t slash = path.find('/', 1);; slash = path.find('/', slash + 1)) {
    const std::string prefix = path.substr(0, slash);
    if (H5Lexists(file, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
    if (slash == std::string::npos) return true;
  }
}

// A quick run of a tiny phantom scene: two threads, no progress, no video.
pipeline::RunOptions TinyRun(const std::string& scene, const std::string& out_dir) {
  pipeline::RunOptions options;
  options.scene = scene;
  options.out_dir = out_dir;
  options.threads = 2;
  options.progress = false;
  options.video = false;
  return options;
}

std::string StepPath(size_t k, const std::string& name) {
  char group[32];
  std::snprintf(group, sizeof group, "/steps/%06zu/", k);
  return group + name;
}

// The .xmf is well formed, lists `steps` steps at the .h5's /time_s, and
// every DataItem it names is a dataset of `h5_name` (beside the .xmf).
void RequireXmfMatchesH5(const std::string& xmf_path, const std::string& h5_name, hid_t file, size_t steps) {
  const std::string xmf = ReadText(xmf_path);
  REQUIRE(dg::io::testing::XmlProblem(xmf) == "");
  const std::vector<std::string> times = Matches(xmf, R"re(<Time Value="([^"]+)"/>)re");
  REQUIRE(times.size() == steps);
  const std::vector<double> time_s = Doubles(file, "/time_s");
  REQUIRE(time_s.size() == steps);
  for (size_t k = 0; k < steps; ++k) CHECK(std::stod(times[k]) == time_s[k]);
  const std::vector<std::string> items = Matches(xmf, R"re(<DataItem[^>]*>([^<]+)</DataItem>)re");
  REQUIRE(items.size() >= 3 * steps);  // topology, geometry and displacement at least
  for (const std::string& item : items) {
    const size_t colon = item.find(':');
    REQUIRE(colon != std::string::npos);
    CHECK(item.substr(0, colon) == h5_name);
    INFO(item);
    CHECK(Exists(file, item.substr(colon + 1)));
  }
}

// ParaView's own XDMF reader (pvpython, Debian's `paraview`), where installed:
// the number of time steps and of points it finds. Empty without pvpython.
std::vector<long long> ParaViewCounts(const std::string& xmf_path) {
  const char* pvpython = "/usr/bin/pvpython";
  if (!fs::exists(pvpython)) return {};
  const std::string script = fs::path(xmf_path).replace_extension(".py").string();
  std::ofstream(script) << "from paraview.simple import XDMFReader\n"
                           "r = XDMFReader(FileNames=['"
                        << xmf_path
                        << "'])\n"
                           "r.UpdatePipelineInformation()\n"
                           "r.UpdatePipeline(r.TimestepValues[-1])\n"
                           "print('counts', len(r.TimestepValues), r.GetDataInformation().GetNumberOfPoints())\n";
  const std::string command = std::string(pvpython) + " --force-offscreen-rendering " + script + " 2>&1";
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(command.c_str(), "r"), pclose);
  REQUIRE(pipe);
  std::string output;
  char buffer[512];
  while (fgets(buffer, sizeof buffer, pipe.get())) output += buffer;
  INFO(output);
  std::smatch match;
  REQUIRE(std::regex_search(output, match, std::regex(R"(counts (\d+) (\d+))")));
  return {std::stoll(match[1]), std::stoll(match[2])};
}

}  // namespace

// A run with --mesh-series on the tiny phantom (combined mode, registered on
// frame 19 of 30): one step per simulated frame at the frame's video time;
// at the run log's 256 sampled nodes, the step's positions are the log's
// (which it stores as float: equal to float rounding); per frame, the tied
// nodes number the log's constrained_nodes; the recovered forces are there
// and finite; the .xmf names only datasets of the .h5.
TEST_CASE("run: --mesh-series writes the simulated mesh per frame, as the run log records it",
          "[tools][integration]") {
  pipeline::RunOptions options = TinyRun(TinyPhantomDir() + "/scene.yaml", TinyPhantomDir() + "/run_mesh_series");
  options.mesh_series = true;
  const pipeline::RunOutcome outcome = pipeline::RunScene(options);
  REQUIRE(outcome.mesh_series_path == options.out_dir + "/mesh_series.xmf");

  const hid_t log = H5Fopen(outcome.log_path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(log >= 0);
  const std::vector<double> log_t_s = Doubles(log, "/sim/t_s");
  const std::vector<double> log_tied = Doubles(log, "/sim/constrained_nodes");
  const std::vector<double> sampled_ids = Doubles(log, "/sim/sampled_node_ids");
  const std::vector<double> sampled_S_m = Doubles(log, "/sim/sampled_nodes_S_m");
  const size_t frames = log_t_s.size();
  REQUIRE(static_cast<long long>(frames) == IntAttribute(log, "/", "simulated_frames"));
  REQUIRE(frames == 11);  // frames 19 to 29
  H5Fclose(log);
  // The mesh's node count as the phantom wrote its motion, not as the run read it.
  const hid_t scan = H5Fopen((TinyPhantomDir() + "/scan.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(scan >= 0);
  const hsize_t nodes = Dims(scan, "/phases/node_displacement_m").at(1);
  H5Fclose(scan);

  const hid_t file = H5Fopen((options.out_dir + "/mesh_series.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(IntAttribute(file, "/", "complete") == 1);
  REQUIRE(Dims(file, "/mesh/geometry_m") == std::vector<hsize_t>{nodes, 3});
  const std::vector<double> reference_m = Doubles(file, "/mesh/geometry_m");
  REQUIRE(Doubles(file, "/time_s") == log_t_s);  // video time, the same doubles
  double worst_sample_m = 0;
  for (size_t k = 0; k < frames; ++k) {
    INFO("step " << k);
    REQUIRE(Dims(file, StepPath(k, "displacement_m")) == std::vector<hsize_t>{nodes, 3});
    const std::vector<double> u_m = Doubles(file, StepPath(k, "displacement_m").c_str());
    const std::vector<double> deformed_m = Doubles(file, StepPath(k, "geometry_m").c_str());
    for (size_t i = 0; i < u_m.size(); ++i) REQUIRE(deformed_m[i] == Approx(reference_m[i] + u_m[i]).margin(1e-15));
    for (size_t s = 0; s < sampled_ids.size(); ++s) {
      const size_t node = static_cast<size_t>(sampled_ids[s]);
      for (size_t i = 0; i < 3; ++i) {
        const double logged = sampled_S_m[(k * sampled_ids.size() + s) * 3 + i];
        worst_sample_m = std::max(worst_sample_m, std::abs(deformed_m[3 * node + i] - logged));
      }
    }
    const std::vector<double> tied = Doubles(file, StepPath(k, "point/tied").c_str());
    REQUIRE(tied.size() == nodes);
    double count = 0;
    for (double t : tied) {
      REQUIRE((t == 0 || t == 1));
      count += t;
    }
    CHECK(count == log_tied[k]);
    CHECK(count > 0);
    REQUIRE(Dims(file, StepPath(k, "point/recovered_force_n")) == std::vector<hsize_t>{nodes, 3});
    double largest_n = 0;
    for (double f : Doubles(file, StepPath(k, "point/recovered_force_n").c_str())) {
      REQUIRE(std::isfinite(f));
      largest_n = std::max(largest_n, std::abs(f));
    }
    CHECK(largest_n > 0);
  }
  // The log stores positions as float (~0.1 m: a float's step there is 7.5e-9 m).
  INFO("largest difference at the sampled nodes: " << worst_sample_m << " m");
  CHECK(worst_sample_m <= 4e-9);
  RequireXmfMatchesH5(outcome.mesh_series_path, "mesh_series.h5", file, frames);
  H5Fclose(file);

  const std::vector<long long> paraview = ParaViewCounts(outcome.mesh_series_path);
  if (paraview.empty()) {
    WARN("pvpython (Debian's paraview) is not installed: the series was not read through ParaView");
  } else {
    CHECK(paraview[0] == static_cast<long long>(frames));
    CHECK(paraview[1] == static_cast<long long>(nodes));
  }
}

// The phantom's scan.xmf plays scan.h5's motion: one step per phase at its
// time in the cycle, each step's displacement scan.h5's for that phase.
TEST_CASE("phantom: scan.xmf plays scan.h5's per-phase node displacement", "[tools][integration]") {
  const std::string dir = TinyPhantomDir();
  const hid_t scan = H5Fopen((dir + "/scan.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(scan >= 0);
  const std::vector<hsize_t> dims = Dims(scan, "/phases/node_displacement_m");
  const std::vector<double> motion_m = Doubles(scan, "/phases/node_displacement_m");
  const std::vector<double> phase = Doubles(scan, "/phases/phase");
  double period_s = 0;
  const hid_t period = H5Aopen(scan, "period_s", H5P_DEFAULT);
  REQUIRE(period >= 0);
  REQUIRE(H5Aread(period, H5T_NATIVE_DOUBLE, &period_s) >= 0);
  H5Aclose(period);
  H5Fclose(scan);
  const size_t phases = dims.at(0), nodes = dims.at(1);

  const hid_t file = H5Fopen((dir + "/scan_series.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(IntAttribute(file, "/", "complete") == 1);
  REQUIRE(Dims(file, "/mesh/geometry_m") == std::vector<hsize_t>{nodes, 3});
  const std::vector<double> time_s = Doubles(file, "/time_s");
  REQUIRE(time_s.size() == phases);
  for (size_t k = 0; k < phases; ++k) {
    INFO("phase " << k);
    CHECK(time_s[k] == Approx(phase[k] * period_s).margin(1e-12));
    const std::vector<double> u_m = Doubles(file, StepPath(k, "displacement_m").c_str());
    REQUIRE(u_m.size() == 3 * nodes);
    REQUIRE(std::equal(u_m.begin(), u_m.end(), motion_m.begin() + k * 3 * nodes));
  }
  RequireXmfMatchesH5(dir + "/scan.xmf", "scan_series.h5", file, phases);
  H5Fclose(file);
}


// In surface mode nothing is recovered: the series holds no forces, and
// still the tied nodes; left unset, --mesh-series is on for so short a run.
// A scene without simulation has no mesh to write: asking for the series is
// refused before the run starts.
TEST_CASE("run: the mesh series in surface mode, by default, and refused without simulation",
          "[tools][integration]") {
  const std::string dir = TinyPhantomDir();
  std::string text = ReadText(dir + "/scene.yaml");
  const size_t mode = text.find("  mode: combined");
  REQUIRE(mode != std::string::npos);
  std::ofstream(dir + "/scene_surface.yaml") << text.replace(mode, 16, "  mode: surface");
  pipeline::RunOptions options = TinyRun(dir + "/scene_surface.yaml", dir + "/run_mesh_series_surface");
  const pipeline::RunOutcome outcome = pipeline::RunScene(options);
  REQUIRE(outcome.mesh_series_path == options.out_dir + "/mesh_series.xmf");
  const hid_t file = H5Fopen((options.out_dir + "/mesh_series.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(IntAttribute(file, "/", "complete") == 1);
  const size_t frames = Doubles(file, "/time_s").size();
  CHECK(static_cast<std::int64_t>(frames) == outcome.simulated_frames);
  for (size_t k = 0; k < frames; ++k) {
    CHECK(Exists(file, StepPath(k, "point/tied")));
    CHECK_FALSE(Exists(file, StepPath(k, "point/recovered_force_n")));
  }
  RequireXmfMatchesH5(outcome.mesh_series_path, "mesh_series.h5", file, frames);
  H5Fclose(file);
  CHECK_THAT(ReadText(outcome.mesh_series_path), !Catch::Contains("recovered_force_n"));

  // The scene without its simulation: block.
  std::string plain = ReadText(dir + "/scene.yaml");
  const size_t begin = plain.find("\nsimulation:");
  REQUIRE(begin != std::string::npos);
  plain.erase(begin + 1, plain.find("\ntruth:") - begin);
  std::ofstream(dir + "/scene_no_simulation.yaml") << plain;
  options.scene = dir + "/scene_no_simulation.yaml";
  options.out_dir = dir + "/run_no_simulation";
  options.mesh_series = true;
  REQUIRE_THROWS_WITH(pipeline::RunScene(options), Catch::Contains("--mesh-series asks for the simulated mesh") &&
                                             Catch::Contains("add a simulation: block"));
}

}  // namespace dg::tools
