#include "tools/sim/sim_runner.h"

#include <cmath>
#include <filesystem>
#include <vector>

#include <catch2/catch.hpp>
#include <hdf5.h>

#include "io/gmsh_mesher.h"
#include "sim/error.h"
#include "tests/support/temporary_folder.h"
#include "tests/support/text_file.h"
#include "tools/sim/builtin_problem.h"

namespace dg::tools {
namespace {

using testing::ReadText;

// The root attribute "complete" of an HDF5 file, read through the HDF5 C API.
int CompleteAttribute(const std::string& path) {
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  const hid_t attribute = H5Aopen(file, "complete", H5P_DEFAULT);
  REQUIRE(attribute >= 0);
  int complete = -1;
  H5Aread(attribute, H5T_NATIVE_INT, &complete);
  H5Aclose(attribute);
  H5Fclose(file);
  return complete;
}

}  // namespace

// The built-in example (20k tets, 1 s) gives the same displacement field in
// float and double to 1e-4 of the largest displacement, and the same reaction.
// (Its max |u| is the prescribed 10 mm in both by construction; the field is the real check.)
TEST_CASE("sim runner: built-in example agrees in float and double", "[tools][integration]") {
  io::SimProblem problem = io::ParseSimProblem(kBuiltinProblem, "<built-in example>", ".");
  const sim::TetMesh mesh = io::LoadProblemMesh(problem.mesh);
  SimRunOptions options;
  options.write_output = false;
  options.progress = false;
  problem.precision = sim::Precision::kFloat;
  const SimSummary single = RunSimProblem(problem, mesh, options);
  problem.precision = sim::Precision::kDouble;
  const SimSummary twice = RunSimProblem(problem, mesh, options);

  REQUIRE(single.steps == 5000);
  REQUIRE(single.simulated_s == Approx(1.0));
  REQUIRE(twice.max_displacement_m == Approx(0.01).epsilon(1e-12));
  const double largest = twice.final_displacement_m.colwise().norm().maxCoeff();
  REQUIRE((single.final_displacement_m - twice.final_displacement_m).cwiseAbs().maxCoeff() < 1e-4 * largest);
  REQUIRE(single.reactions_n.at(0).second.z() ==
          Approx(twice.reactions_n.at(0).second.z()).epsilon(1e-4));
  REQUIRE(twice.reactions_n.at(0).second.z() < 0);  // the support pushes the top down
}

// A run that inverts elements stops with the named error and leaves its
// outputs readable and marked incomplete.
TEST_CASE("sim runner: a failed run leaves incomplete, readable outputs", "[tools][unit]") {
  const std::string crush = R"(mesh:
  generate: box
  tets: 400
fixed:
  - set: zmin
prescribed:
  - set: zmax
    displacement_m: [0, 0, -0.06]
    ramp: linear
    ramp_s: 0.05
duration_s: 0.1
output_every_s: 0.005
)";
  const io::SimProblem problem = io::ParseSimProblem(crush, "crush.yaml", ".");
  const sim::TetMesh mesh = io::LoadProblemMesh(problem.mesh);
  const testing::TemporaryFolder folder("dg_sim_runner_crush");
  const std::string& out = folder.path();
  SimRunOptions options;
  options.out_dir = out;
  options.progress = false;
  REQUIRE_THROWS_WITH(RunSimProblem(problem, mesh, options), Catch::Contains("inverted element"));
  REQUIRE(ReadText(out + "/summary.json").find("\"status\": \"incomplete: error\"") != std::string::npos);
  REQUIRE(CompleteAttribute(out + "/sim.h5") == 0);
  REQUIRE(std::filesystem::exists(out + "/sim.xmf"));
}

// Every value of every step in a file, through the HDF5 C API: the number of
// non-finite ones, and the steps read.
struct FiniteCount {
  long long non_finite = 0, datasets = 0;
};
herr_t CountNonFinite(hid_t object, const char* name, const H5O_info_t* info, void* data) {
  if (info->type != H5O_TYPE_DATASET) return 0;
  const hid_t set = H5Dopen2(object, name, H5P_DEFAULT);
  const hid_t space = H5Dget_space(set);
  std::vector<double> values(static_cast<size_t>(H5Sget_simple_extent_npoints(space)));
  const bool floating = H5Tget_class(H5Dget_type(set)) == H5T_FLOAT;
  if (floating && !values.empty()) {
    H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
    auto& count = *static_cast<FiniteCount*>(data);
    ++count.datasets;
    for (double v : values) count.non_finite += !std::isfinite(v);
  }
  H5Sclose(space);
  H5Dclose(set);
  return 0;
}

// Run unchecked at ten times the safe step, the solution diverges: the run
// stops naming the time step as the cause (not the load), and no inverted
// element's stress (NaN) reaches the file: a state goes to an output only
// after its elements are checked.
TEST_CASE("sim runner: unchecked above the stability limit, nothing non-finite is written", "[tools][integration]") {
  io::SimProblem problem = io::ParseSimProblem(kBuiltinProblem, "<built-in example>", ".");
  problem.solver.time_step_policy = sim::TimeStepPolicy::kUnchecked;
  problem.solver.dt_s = 4e-3;  // the 20k box's safe step is 0.39 ms
  problem.output_every_s = 4e-3;
  const sim::TetMesh mesh = io::LoadProblemMesh(problem.mesh);
  const testing::TemporaryFolder folder("dg_sim_runner_unchecked");
  const std::string& out = folder.path();
  SimRunOptions options;
  options.out_dir = out;
  options.progress = false;
  REQUIRE_THROWS_WITH(RunSimProblem(problem, mesh, options),
                      Catch::Contains("inverted element: the time step 4 ms is above the stability limit"));
  REQUIRE(CompleteAttribute(out + "/sim.h5") == 0);
  const hid_t file = H5Fopen((out + "/sim.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  FiniteCount count;
  H5Ovisit2(file, H5_INDEX_NAME, H5_ITER_INC, CountNonFinite, &count, H5O_INFO_BASIC);
  H5Fclose(file);
  CHECK(count.datasets > 3);  // the mesh and the steps before the divergence
  CHECK(count.non_finite == 0);
}

// A problem may name any Gmsh file (in mm) and select its nodes geometrically;
// at the end the fixed nodes are at rest and the selected top nodes at their target.
TEST_CASE("sim runner: problem on a .msh file with plane and box selections", "[tools][unit]") {
  const std::string problem_text = R"(mesh:
  file: )" + std::string(DG_SOURCE_DIR) + R"(/tests/io/fixtures/box_with_hole_v41.msh
  units: mm
fixed:
  - plane: {point_m: [0, 0, 0], normal: [0, 0, 1], tolerance_m: 1.0e-6}
prescribed:
  - name: lid
    box: {lo_m: [0, 0, 0.02], hi_m: [0.04, 0.03, 0.02], tolerance_m: 1.0e-6}
    axes: z
    displacement_m: [0, 0, -0.0002]
    ramp_s: 0.02
duration_s: 0.05
)";
  const io::SimProblem problem = io::ParseSimProblem(problem_text, "hole.yaml", ".");
  const sim::TetMesh mesh = io::LoadProblemMesh(problem.mesh);
  SimRunOptions options;
  options.write_output = false;
  options.progress = false;
  const SimSummary summary = RunSimProblem(problem, mesh, options);
  REQUIRE(summary.steps == 250);
  for (int a = 0; a < mesh.num_nodes(); ++a) {
    const double z = mesh.X_m(2, a);
    if (z < 1e-9) REQUIRE(summary.final_displacement_m.col(a).norm() == 0);
    if (z > 0.02 - 1e-9) REQUIRE(summary.final_displacement_m(2, a) == Approx(-0.0002).epsilon(1e-6));
  }
  REQUIRE(summary.reactions_n.at(0).first == "lid");
  REQUIRE(summary.reactions_n.at(0).second.z() < 0);
}

}  // namespace dg::tools
