#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sim/material.h"
#include "sim/precision.h"
#include "sim/tet_mesh.h"
#include "sim/tled_solver.h"

namespace dg::io {

// Which nodes a boundary condition acts on: exactly one of a named node set
// (a physical group of the mesh), a plane with a tolerance, or a box.
struct NodeSelection {
  std::string set;
  struct Plane {
    Eigen::Vector3d point_m, normal;
    double tolerance_m;
  };
  std::optional<Plane> plane;
  struct Box {
    Eigen::Vector3d lo_m, hi_m;
    double tolerance_m;
  };
  std::optional<Box> box;
  std::string where;  // file:line of the selection, for errors

  std::string Describe() const;
};

struct FixedCondition {
  NodeSelection nodes;
  std::array<bool, 3> axes{true, true, true};
};

// Moves the selected nodes' given axes by displacement_m along a ramp from 0
// to 1 over ramp_s, then holds. "quintic" is 10 s^3 - 15 s^4 + 6 s^5 (zero
// velocity and acceleration at both ends); "linear" is s.
struct PrescribedCondition {
  std::string name;
  NodeSelection nodes;
  std::array<bool, 3> axes{true, true, true};
  Eigen::Vector3d displacement_m = Eigen::Vector3d::Zero();
  double ramp_s = 0.0;
  std::string ramp = "quintic";

  // The fraction of the displacement applied at time t.
  double RampFraction(double t_s) const;
};

// Where the mesh comes from: a Gmsh file, or a box or ellipsoid meshed by Gmsh's SDK.
struct MeshSource {
  std::string file;              // absolute, resolved against the problem file
  double metres_per_unit = 1.0;  // for the file's coordinates
  std::string generate;          // "box" or "ellipsoid" when no file
  Eigen::Vector3d size_m{0.05, 0.05, 0.05};  // box edge lengths or ellipsoid semi-axes
  int tets = 20000;
};

// A `dynaguide sim` problem: one YAML file
// (`dynaguide sim --print-example` shows every key, with units in the key names).
struct SimProblem {
  MeshSource mesh;
  sim::Material material;
  sim::SolverOptions solver;
  sim::Precision precision = sim::Precision::kFloat;
  double duration_s = 1.0;
  double output_every_s = 0.01;
  std::vector<FixedCondition> fixed;
  std::vector<PrescribedCondition> prescribed;
  std::string text;  // the YAML as read, verbatim
  std::string path;  // the file, or "<built-in>"
};

// @throws dg::Error naming the file, line and key for an unknown key, a
// wrong type or range, or a missing required entry.
SimProblem ParseSimProblem(const std::string& yaml_text, const std::string& path,
                           const std::string& base_directory);
SimProblem ReadSimProblem(const std::string& path);

// Reads or generates the mesh. @throws dg::Error from the reader or mesher.
sim::TetMesh LoadProblemMesh(const MeshSource& source);

// The sorted node ids a selection picks. @throws dg::Error for an unknown set
// (listing the mesh's sets) or an empty selection.
std::vector<int> SelectNodes(const sim::TetMesh& mesh, const NodeSelection& selection);

// Degrees of freedom (3 node + axis) of the fixed and prescribed conditions;
// prescribed_owner[k] is the index of the condition that drives prescribed dof k.
struct ProblemDofs {
  sim::BoundaryConditions conditions;
  std::vector<int> prescribed_owner;
  std::vector<double> prescribed_full_m;  // each prescribed dof's displacement at ramp end
};
// @throws dg::Error if a dof is both fixed and prescribed by different conditions.
ProblemDofs ResolveConditions(const sim::TetMesh& mesh, const SimProblem& problem);

}  // namespace dg::io
