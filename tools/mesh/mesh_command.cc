// dynaguide mesh box|ellipsoid: tetrahedral meshes of a target size through
// Gmsh's SDK, written as .msh files with their physical groups, for tests,
// benchmarks and examples.
#include "tools/commands.h"

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "io/gmsh_mesher.h"

namespace dg::tools {
namespace {

struct MeshOptions {
  std::vector<double> lengths_m;
  int target_tets = 20000;
  std::string out;
  std::string format = "msh41";
};

// Checked at parsing, so a bad path fails before a meshing that may take seconds.
std::string CheckOutPath(const std::string& path) {
  const std::filesystem::path out(path);
  if (out.extension() != ".msh") return "the output file must end in .msh: " + path;
  if (!out.parent_path().empty() && !std::filesystem::is_directory(out.parent_path())) {
    return "no such folder: " + out.parent_path().string();
  }
  return "";
}

void AddCommonOptions(CLI::App& command, MeshOptions& options) {
  command.add_option("--tets", options.target_tets, "target number of tetrahedra (within 15%)")
      ->capture_default_str();
  command.add_option("--out", options.out, "output mesh file, FILE.msh")
      ->required()
      ->check(CheckOutPath, "FILE.msh");
  command.add_option("--format", options.format, "Gmsh ASCII format of the output")
      ->check(CLI::IsMember({"msh22", "msh41"}))
      ->capture_default_str();
}

Eigen::Vector3d ToVector(const std::vector<double>& v) { return {v[0], v[1], v[2]}; }

// Writes the mesh and prints one summary line on stdout.
void Finish(const std::string& shape, const sim::TetMesh& mesh, const io::MeshReport& report,
            const MeshOptions& options) {
  io::WriteMsh(mesh, options.out, options.format == "msh22" ? 22 : 41);
  std::printf("%s\n",
              fmt::format("{}: {} nodes, {} tets (target {}), volume {:.6g} m^3, min radius ratio "
                          "{:.3f}, meshed in {:.0f} ms -> {} ({})",
                          shape, mesh.num_nodes(), mesh.num_tets(), options.target_tets,
                          report.volume_m3, report.min_radius_ratio, report.wall_ms, options.out,
                          options.format)
                  .c_str());
}

}  // namespace

void AddMeshCommand(CLI::App& app) {
  CLI::App* mesh = app.add_subcommand("mesh", "make a tetrahedral mesh with Gmsh and write it as .msh");
  mesh->require_subcommand(1);

  auto box_options = std::make_shared<MeshOptions>();
  box_options->lengths_m = {0.05, 0.05, 0.05};
  CLI::App* box = mesh->add_subcommand("box", "a box with its min corner at the origin; physical "
                                              "surfaces xmin..zmax, volume body");
  box->add_option("--size", box_options->lengths_m, "edge lengths X Y Z in metres")
      ->expected(3)
      ->capture_default_str();
  AddCommonOptions(*box, *box_options);
  box->callback([box_options] {
    io::BoxSpec spec;
    spec.size_m = ToVector(box_options->lengths_m);
    spec.target_tets = box_options->target_tets;
    io::MeshReport report;
    const sim::TetMesh mesh = io::MeshBox(spec, &report);
    Finish(fmt::format("box {} x {} x {} m", spec.size_m.x(), spec.size_m.y(), spec.size_m.z()),
           mesh, report, *box_options);
  });

  auto ellipsoid_options = std::make_shared<MeshOptions>();
  ellipsoid_options->lengths_m = {0.03, 0.02, 0.02};
  CLI::App* ellipsoid = mesh->add_subcommand(
      "ellipsoid", "an ellipsoid centred at the origin; physical surface 'surface', volume body");
  ellipsoid->add_option("--semi-axes", ellipsoid_options->lengths_m, "semi-axes A B C in metres")
      ->expected(3)
      ->capture_default_str();
  AddCommonOptions(*ellipsoid, *ellipsoid_options);
  ellipsoid->callback([ellipsoid_options] {
    io::EllipsoidSpec spec;
    spec.semi_axes_m = ToVector(ellipsoid_options->lengths_m);
    spec.target_tets = ellipsoid_options->target_tets;
    io::MeshReport report;
    const sim::TetMesh mesh = io::MeshEllipsoid(spec, &report);
    Finish(fmt::format("ellipsoid semi-axes {} x {} x {} m", spec.semi_axes_m.x(),
                       spec.semi_axes_m.y(), spec.semi_axes_m.z()),
           mesh, report, *ellipsoid_options);
  });
}

}  // namespace dg::tools
