#include "io/sim_problem.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "io/gmsh_mesher.h"
#include "io/gmsh_reader.h"
#include "io/input_file.h"
#include "io/units.h"
#include "io/yaml_map.h"
#include "sim/error.h"

namespace dg::io {
namespace {

std::array<bool, 3> ParseAxes(const YamlMap& map) {
  const std::string axes = map.String("axes", "xyz");
  std::array<bool, 3> chosen{false, false, false};
  for (char c : axes) {
    if (c < 'x' || c > 'z' || chosen[c - 'x']) {
      throw Error("'axes' must be a combination of x, y, z without repeats (got '" + axes + "')",
                  map.Where("axes"), "write e.g. 'xyz', 'z' or 'xy'");
    }
    chosen[c - 'x'] = true;
  }
  if (axes.empty()) throw Error("'axes' is empty", map.Where("axes"), "name at least one of x, y, z");
  return chosen;
}

NodeSelection ParseSelection(const YamlMap& map) {
  NodeSelection selection;
  selection.where = map.Where();
  int given = 0;
  if (map.Has("set")) {
    selection.set = map.String("set");
    ++given;
  }
  if (map.Has("plane")) {
    const YamlMap plane = map.Map("plane");
    selection.plane = NodeSelection::Plane{plane.Vector3("point_m"), plane.Vector3("normal"),
                                           plane.Number("tolerance_m", 1e-6)};
    plane.RejectUnknown();
    ++given;
  }
  if (map.Has("box")) {
    const YamlMap box = map.Map("box");
    selection.box = NodeSelection::Box{box.Vector3("lo_m"), box.Vector3("hi_m"), box.Number("tolerance_m", 1e-6)};
    box.RejectUnknown();
    ++given;
  }
  if (given != 1) {
    throw Error("a condition needs exactly one of 'set', 'plane' or 'box' (got " + std::to_string(given) + ")",
                map.Where(), "name a node set of the mesh, or select nodes geometrically");
  }
  return selection;
}

void RequirePositive(double value, const YamlMap& map, const std::string& key) {
  if (!(value > 0) || !std::isfinite(value)) {
    throw Error("'" + key + "' must be positive and finite", map.Where(key), "give a positive number");
  }
}

MeshSource ParseMesh(const YamlMap& map, const std::string& base_directory) {
  MeshSource mesh;
  if (map.Has("file")) {
    mesh.file = (std::filesystem::path(base_directory) / map.String("file")).lexically_normal().string();
    mesh.metres_per_unit = MetresPerUnit(map.String("units", "m"), map.Where("units"));
  } else {
    mesh.generate = map.String("generate", "box");
    if (mesh.generate != "box" && mesh.generate != "ellipsoid") {
      throw Error("'generate' must be 'box' or 'ellipsoid' (got '" + mesh.generate + "')", map.Where("generate"),
                  "or give 'file: your.msh'");
    }
  }
  if (map.Has("units") && mesh.file.empty()) {
    throw Error("'units' applies to a mesh file only", map.Where("units"), "remove it; generated sizes are in metres");
  }
  mesh.size_m = map.Vector3("size_m", mesh.size_m);
  mesh.tets = map.Integer("tets", mesh.tets);
  if (!mesh.file.empty() && (map.Has("size_m") || map.Has("tets"))) {
    throw Error("'size_m' and 'tets' apply to generated meshes only", map.Where(),
                "remove them, or remove 'file' to generate a mesh");
  }
  if (mesh.tets < 1) throw Error("'tets' must be positive", map.Where("tets"), "give e.g. 20000");
  map.RejectUnknown();
  return mesh;
}

sim::TimeStepPolicy ParsePolicy(const YamlMap& map) {
  return sim::ParseTimeStepPolicy(map.String("time_step_policy", sim::ToString(sim::TimeStepPolicy::kRefuse)),
                                  map.Where("time_step_policy"));
}

}  // namespace

std::string NodeSelection::Describe() const {
  if (!set.empty()) return "node set '" + set + "'";
  if (plane) return "plane selection at " + where;
  return "box selection at " + where;
}

double PrescribedCondition::RampFraction(double t_s) const {
  if (ramp_s <= 0 || t_s >= ramp_s) return 1.0;
  const double s = std::max(0.0, t_s / ramp_s);
  return ramp == "linear" ? s : s * s * s * (10 - 15 * s + 6 * s * s);
}

SimProblem ParseSimProblem(const std::string& yaml_text, const std::string& path,
                           const std::string& base_directory) {
  const YamlMap top(ParseYaml(yaml_text, path), path, "");
  SimProblem problem;
  problem.text = yaml_text;
  problem.path = path;

  problem.mesh = ParseMesh(top.Map("mesh"), base_directory);

  if (top.Has("material")) problem.material = ReadMaterial(top.Map("material"));

  if (top.Has("solver")) {
    const YamlMap map = top.Map("solver");
    sim::SolverOptions& solver = problem.solver;
    solver.dt_s = map.Number("dt_s", solver.dt_s);
    solver.damping_per_s = map.Number("damping_per_s", solver.damping_per_s);
    solver.stability_safety = map.Number("stability_safety", solver.stability_safety);
    solver.time_step_policy = ParsePolicy(map);
    problem.precision =
        sim::ParsePrecision(map.String("precision", sim::ToString(problem.precision)), map.Where("precision"));
    map.RejectUnknown();
  }
  problem.solver.gravity_m_s2 = top.Vector3("gravity_m_s2", Eigen::Vector3d::Zero());
  if (const std::string wrong = problem.solver.Validate(); !wrong.empty()) {
    throw Error(wrong, top.Where("solver"), "correct the solver options");
  }

  problem.duration_s = top.Number("duration_s", problem.duration_s);
  RequirePositive(problem.duration_s, top, "duration_s");
  problem.output_every_s = top.Number("output_every_s", problem.output_every_s);
  RequirePositive(problem.output_every_s, top, "output_every_s");

  if (top.Has("fixed")) {
    const YAML::Node list = top.Node("fixed");
    if (!list.IsSequence()) throw Error("'fixed' must be a list", top.Where("fixed"), "write '- set: NAME' items");
    for (size_t i = 0; i < list.size(); ++i) {
      const YamlMap map(list[i], path, "fixed[" + std::to_string(i) + "]");
      problem.fixed.push_back({ParseSelection(map), ParseAxes(map)});
      map.RejectUnknown();
    }
  }
  if (top.Has("prescribed")) {
    const YAML::Node list = top.Node("prescribed");
    if (!list.IsSequence()) {
      throw Error("'prescribed' must be a list", top.Where("prescribed"), "write '- set: NAME' items");
    }
    for (size_t i = 0; i < list.size(); ++i) {
      const YamlMap map(list[i], path, "prescribed[" + std::to_string(i) + "]");
      PrescribedCondition condition;
      condition.nodes = ParseSelection(map);
      condition.name = map.String("name", condition.nodes.set.empty() ? "prescribed[" + std::to_string(i) + "]"
                                                                      : condition.nodes.set);
      condition.axes = ParseAxes(map);
      condition.displacement_m = map.Vector3("displacement_m");
      condition.ramp_s = map.Number("ramp_s", 0.0);
      condition.ramp = map.String("ramp", "quintic");
      if (condition.ramp != "quintic" && condition.ramp != "linear") {
        throw Error("'ramp' must be quintic or linear", map.Where("ramp"), "choose one");
      }
      if (!condition.displacement_m.allFinite() || !(condition.ramp_s >= 0)) {
        throw Error("displacement must be finite and ramp_s non-negative", map.Where(), "correct the values");
      }
      map.RejectUnknown();
      problem.prescribed.push_back(condition);
    }
  }
  top.RejectUnknown();
  return problem;
}

SimProblem ReadSimProblem(const std::string& path) {
  const std::string text = ReadTextFile(path, "problem file",
                                        "check the path (run 'dynaguide sim' without one for the built-in example)");
  return ParseSimProblem(text, path, std::filesystem::path(path).parent_path().string());
}

sim::TetMesh LoadProblemMesh(const MeshSource& source) {
  if (!source.file.empty()) return ReadGmsh(source.file, source.metres_per_unit);
  if (source.generate == "ellipsoid") return MeshEllipsoid({source.size_m, source.tets});
  return MeshBox({source.size_m, source.tets});
}

std::vector<int> SelectNodes(const sim::TetMesh& mesh, const NodeSelection& selection) {
  std::vector<int> nodes;
  if (!selection.set.empty()) {
    const auto found = mesh.node_sets.find(selection.set);
    if (found == mesh.node_sets.end()) {
      std::string names;
      for (const auto& [name, set] : mesh.node_sets) names += (names.empty() ? "" : ", ") + name;
      throw Error("the mesh has no node set '" + selection.set + "'", selection.where,
                  "use one of: " + (names.empty() ? std::string("(none: select by plane or box)") : names));
    }
    nodes = found->second;
  } else if (selection.plane) {
    nodes = sim::NodesNearPlane(mesh, selection.plane->point_m, selection.plane->normal, selection.plane->tolerance_m);
  } else {
    nodes = sim::NodesInBox(mesh, selection.box->lo_m, selection.box->hi_m, selection.box->tolerance_m);
  }
  if (nodes.empty()) {
    throw Error(selection.Describe() + " selects no nodes", selection.where,
                "check the coordinates (metres) and the tolerance against the mesh's bounding box");
  }
  return nodes;
}

ProblemDofs ResolveConditions(const sim::TetMesh& mesh, const SimProblem& problem) {
  ProblemDofs dofs;
  std::vector<int> owner(3 * mesh.num_nodes(), -1);  // -2 fixed, k prescribed by condition k
  for (const FixedCondition& condition : problem.fixed) {
    for (int a : SelectNodes(mesh, condition.nodes)) {
      for (int axis = 0; axis < 3; ++axis) {
        if (condition.axes[axis]) owner[3 * a + axis] = -2;
      }
    }
  }
  for (size_t k = 0; k < problem.prescribed.size(); ++k) {
    const PrescribedCondition& condition = problem.prescribed[k];
    for (int a : SelectNodes(mesh, condition.nodes)) {
      for (int axis = 0; axis < 3; ++axis) {
        if (!condition.axes[axis]) continue;
        int& current = owner[3 * a + axis];
        if (current != -1 && current != static_cast<int>(k)) {
          throw Error("node " + std::to_string(a) + " axis " + "xyz"[axis] + " is " +
                          (current == -2 ? "fixed" : "prescribed by '" + problem.prescribed[current].name + "'") +
                          " and also prescribed by '" + condition.name + "'",
                      condition.nodes.where, "make the selections disjoint (e.g. shrink the box or plane tolerance)");
        }
        current = static_cast<int>(k);
      }
    }
  }
  for (int dof = 0; dof < 3 * mesh.num_nodes(); ++dof) {
    if (owner[dof] == -2) {
      dofs.conditions.fixed_dofs.push_back(dof);
    } else if (owner[dof] >= 0) {
      dofs.conditions.prescribed_dofs.push_back(dof);
      dofs.prescribed_owner.push_back(owner[dof]);
      dofs.prescribed_full_m.push_back(problem.prescribed[owner[dof]].displacement_m[dof % 3]);
    }
  }
  return dofs;
}

}  // namespace dg::io
