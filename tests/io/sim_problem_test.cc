#include "io/sim_problem.h"

#include <catch2/catch.hpp>

#include "sim/error.h"
#include "tests/sim/box_mesh.h"

namespace dg::io {
namespace {

constexpr char kMinimal[] = R"(mesh:
  generate: box
  tets: 500
fixed:
  - set: zmin
prescribed:
  - set: zmax
    axes: z
    displacement_m: [0, 0, -0.001]
    ramp_s: 0.1
)";

SimProblem Parse(const std::string& text) { return ParseSimProblem(text, "problem.yaml", "/base"); }

}  // namespace

// Defaults are the paper's; the keys given are read with their units.
TEST_CASE("sim problem: minimal problem takes the paper's defaults", "[io][unit]") {
  const SimProblem problem = Parse(kMinimal);
  REQUIRE(problem.material.youngs_modulus_pa == 3000);
  REQUIRE(problem.material.poissons_ratio == 0.45);
  REQUIRE(problem.solver.dt_s == 2e-4);
  REQUIRE(problem.solver.damping_per_s == 75);
  REQUIRE(problem.mesh.tets == 500);
  REQUIRE(problem.prescribed.at(0).name == "zmax");
  REQUIRE(problem.prescribed.at(0).axes == std::array<bool, 3>{false, false, true});
}

// A misspelt key is an error naming the file, line and key path.
TEST_CASE("sim problem: unknown key names file, line and key", "[io][unit]") {
  std::string text = kMinimal;
  text.replace(text.find("ramp_s"), 6, "ramp_sec");
  REQUIRE_THROWS_WITH(Parse(text), Catch::Contains("unknown key 'ramp_sec'") &&
                                       Catch::Contains("problem.yaml:10") &&
                                       Catch::Contains("prescribed[0].ramp_sec"));
  REQUIRE_THROWS_WITH(Parse(std::string(kMinimal) + "materail:\n  poissons_ratio: 0.4\n"),
                      Catch::Contains("unknown key 'materail'"));
}

// Wrong types and ranges are errors naming the key.
TEST_CASE("sim problem: wrong types and values are named", "[io][unit]") {
  REQUIRE_THROWS_WITH(Parse(std::string(kMinimal) + "duration_s: soon\n"),
                      Catch::Contains("'duration_s' must be a number") && Catch::Contains("problem.yaml:11"));
  REQUIRE_THROWS_WITH(Parse(std::string(kMinimal) + "material:\n  poissons_ratio: 0.5\n"),
                      Catch::Contains("Poisson") && Catch::Contains("material"));
  REQUIRE_THROWS_WITH(Parse(std::string(kMinimal) + "gravity_m_s2: [0, 0]\n"),
                      Catch::Contains("three numbers"));
  std::string text = kMinimal;
  text.replace(text.find("axes: z"), 7, "axes: zz");
  REQUIRE_THROWS_WITH(Parse(text), Catch::Contains("axes"));
}

// Relative mesh paths resolve against the problem file's directory.
TEST_CASE("sim problem: mesh file resolves against the problem", "[io][unit]") {
  std::string text = kMinimal;
  const std::string generated = "  generate: box\n  tets: 500\n";
  text.replace(text.find(generated), generated.size(), "  file: meshes/cube.msh\n  units: mm\n");
  const SimProblem problem = Parse(text);
  REQUIRE(problem.mesh.file == "/base/meshes/cube.msh");
  REQUIRE(problem.mesh.metres_per_unit == 1e-3);
}

// The quintic ramp is 0 and 1 at its ends with zero slope there, 1/2 halfway.
TEST_CASE("sim problem: quintic ramp", "[io][unit]") {
  PrescribedCondition condition;
  condition.ramp_s = 2.0;
  REQUIRE(condition.RampFraction(0) == 0);
  REQUIRE(condition.RampFraction(1.0) == Approx(0.5));
  REQUIRE(condition.RampFraction(2.0) == 1);
  REQUIRE(condition.RampFraction(5.0) == 1);
  const double h = 1e-6;
  REQUIRE(condition.RampFraction(h) / h == Approx(0).margin(1e-9));
  REQUIRE((1 - condition.RampFraction(2.0 - h)) / h == Approx(0).margin(1e-9));
}

// Selections resolve to dofs; unknown sets list the mesh's sets; a dof both
// fixed and prescribed is refused.
TEST_CASE("sim problem: conditions resolve to degrees of freedom", "[io][unit]") {
  const sim::TetMesh mesh = sim::testing::MakeBoxMesh(2, 2, 2, {0.01, 0.01, 0.01});
  SimProblem problem = Parse(kMinimal);
  const ProblemDofs dofs = ResolveConditions(mesh, problem);
  REQUIRE(dofs.conditions.fixed_dofs.size() == 3 * 9);
  REQUIRE(dofs.conditions.prescribed_dofs.size() == 9);
  REQUIRE(dofs.prescribed_full_m.at(0) == -0.001);

  problem.prescribed[0].nodes.set = "top";
  REQUIRE_THROWS_WITH(ResolveConditions(mesh, problem), Catch::Contains("no node set 'top'") &&
                                                            Catch::Contains("zmax"));
  problem.prescribed[0].nodes.set = "xmin";
  REQUIRE_THROWS_WITH(ResolveConditions(mesh, problem), Catch::Contains("fixed") &&
                                                            Catch::Contains("also prescribed"));
}

}  // namespace dg::io
