#include "tools/sim/sim_runner.h"

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>

#include <nlohmann/json.hpp>

#include "io/output_folder.h"
#include "io/vtu_writer.h"
#include "io/xdmf_writer.h"
#include "pipeline/stop_request.h"
#include "sim/element_measures.h"
#include "sim/error.h"
#include "sim/log.h"
#include "sim/progress.h"
#include "sim/tled_solver.h"
#include "tools/json_text.h"

namespace dg::tools {
namespace {

io::MeshFields OutputFields(const sim::TetMesh& mesh, const sim::Material& material, const Eigen::Matrix3Xd& u) {
  const sim::ElementMeasures measures = sim::ComputeElementMeasures(mesh, material, u);
  io::MeshFields fields;
  fields.cell_data.emplace_back("volume_ratio_J", measures.volume_ratio.transpose());
  fields.cell_data.emplace_back("von_mises_stress_Pa", measures.von_mises_pa.transpose());
  return fields;
}

// Written under a temporary name and renamed, so that summary.json is either
// absent or whole: a full disk leaves no empty or cut file.
void WriteSummaryJson(const std::string& path, const SimSummary& s, const std::string& status) {
  using Json = nlohmann::ordered_json;
  const auto figure = [](double value) { return Significant(value, 6); };
  Json reactions = Json::object();
  for (const auto& [boundary, r] : s.reactions_n) reactions[boundary] = {figure(r.x()), figure(r.y()), figure(r.z())};
  const Json json = {{"status", status},
                     {"nodes", s.nodes},
                     {"tets", s.tets},
                     {"precision", sim::ToString(s.precision)},
                     {"steps", s.steps},
                     {"substeps_per_step", s.substeps_per_step},
                     {"dt_s", figure(s.dt_s)},
                     {"simulated_s", figure(s.simulated_s)},
                     {"wall_s", figure(s.wall_s)},
                     {"tet_steps_per_s", figure(s.tet_steps_per_s)},
                     {"realtime_factor", figure(s.realtime_factor)},
                     {"dt_critical_s", figure(s.stability.dt_critical_s)},
                     {"dt_element_bound_s", figure(s.stability.dt_element_bound_s)},
                     {"max_displacement_m", figure(s.max_displacement_m)},
                     {"threads", s.threads},
                     {"reactions_n", reactions}};
  const std::string temporary = path + ".tmp";
  std::ofstream file(temporary);
  file << JsonText(json);
  file.close();
  std::error_code error;
  if (file) std::filesystem::rename(temporary, path, error);
  if (!file || error) {
    const std::string reason = file ? error.message() : std::strerror(errno);
    std::filesystem::remove(temporary, error);
    throw Error("cannot write the summary: " + reason, path,
                "free space on the output's file system or choose another --out");
  }
}

// On the way out of a failed run: the outputs are closed and marked
// incomplete as far as the disk allows, and the run's own error goes on.
void FinishIncomplete(io::XdmfTimeSeriesWriter* series, const std::string& summary_path, const SimSummary& summary,
                      const std::string& status) {
  try {
    if (series) series->Close(false);
    if (!summary_path.empty()) WriteSummaryJson(summary_path, summary, status);
  } catch (const Error& e) {
    Logger("tools").warn("the outputs could not all be marked incomplete: {}", e.what());
  }
}

template <typename T>
SimSummary Run(const io::SimProblem& problem, const sim::TetMesh& mesh, const SimRunOptions& options) {
  const io::ProblemDofs dofs = io::ResolveConditions(mesh, problem);
  auto model = std::make_shared<const sim::TledModel<T>>(mesh, problem.material);
  sim::TledSolver<T> solver(model, dofs.conditions, problem.solver);

  SimSummary summary;
  summary.nodes = mesh.num_nodes();
  summary.tets = mesh.num_tets();
  summary.precision = sim::PrecisionOf<T>();
  summary.threads = options.threads;
  summary.dt_s = problem.solver.dt_s;
  summary.substeps_per_step = solver.substeps_per_step();
  summary.stability = solver.stability();

  std::unique_ptr<io::XdmfTimeSeriesWriter> series;
  std::optional<io::OutputFolderClaim> claim;  // held while the outputs are written
  if (options.write_output) {
    claim.emplace(options.out_dir, "dynaguide sim", SimOutputNames());
    series = std::make_unique<io::XdmfTimeSeriesWriter>(options.out_dir + "/sim", mesh);
  }
  auto write_output = [&] {
    if (!series) return;
    solver.CheckCurrentState();  // no inverted element, no non-finite stress, in a file
    const Eigen::Matrix3Xd u = solver.DisplacementMatrix();
    series->Append(solver.time_s(), u, OutputFields(mesh, problem.material, u));
  };

  const long long total_steps = std::llround(problem.duration_s / problem.solver.dt_s);
  const long long output_every = std::max(1LL, std::llround(problem.output_every_s / problem.solver.dt_s));
  std::vector<double> targets(dofs.conditions.prescribed_dofs.size());
  Progress progress("sim", static_cast<double>(total_steps), options.progress);
  double wall_s = 0;
  std::string stopped_status = "incomplete: error";  // summary.json's status when the stepping stops early
  try {
    write_output();
    for (long long step = 0; step < total_steps;) {
      const long long chunk = std::min(output_every - step % output_every, total_steps - step);
      const auto start = std::chrono::steady_clock::now();
      for (long long k = 0; k < chunk; ++k) {
        // Targets at the end of this step: each condition's ramp at t + dt.
        const double t_next = (step + k + 1) * problem.solver.dt_s;
        for (size_t d = 0; d < targets.size(); ++d) {
          targets[d] = dofs.prescribed_full_m[d] * problem.prescribed[dofs.prescribed_owner[d]].RampFraction(t_next);
        }
        solver.Advance(1, targets);
      }
      wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      step += chunk;
      summary.steps = step;
      if (step % output_every == 0 || step == total_steps) write_output();
      char rate[64];
      std::snprintf(rate, sizeof rate, "t = %.3f s  %.1f M tet-steps/s", solver.time_s(),
                    mesh.num_tets() * double(solver.steps_taken()) / wall_s / 1e6);
      progress.Update(static_cast<double>(step), rate);
      // A stop asked for by a signal (pipeline/stop_request.h), checked at an output step: the outputs end there.
      if (const int signal = pipeline::StopSignal(); signal != 0 && step < total_steps) {
        const std::string what = "interrupted by " + pipeline::SignalName(signal) + " at step " + std::to_string(step);
        stopped_status = "incomplete: " + what;
        throw pipeline::Interrupted(signal, what, options.out_dir,
                                    "the steps up to it are in the outputs (marked incomplete); run again for the "
                                    "whole duration");
      }
    }
  } catch (const Error&) {
    progress.Finish();
    FinishIncomplete(series.get(), options.write_output ? options.out_dir + "/summary.json" : "", summary,
                     stopped_status);
    throw;
  }
  progress.Finish();

  summary.simulated_s = solver.time_s();
  summary.wall_s = wall_s;
  summary.tet_steps_per_s = mesh.num_tets() * double(solver.steps_taken()) / wall_s;
  summary.realtime_factor = summary.simulated_s / wall_s;
  const Eigen::Matrix3Xd u = solver.DisplacementMatrix();
  summary.max_displacement_m = u.colwise().norm().maxCoeff(&summary.max_displacement_node);
  summary.final_displacement_m = u;
  for (const io::PrescribedCondition& condition : problem.prescribed) {
    summary.reactions_n.emplace_back(condition.name, Eigen::Vector3d::Zero());
  }
  for (size_t d = 0; d < dofs.conditions.prescribed_dofs.size(); ++d) {
    const int dof = dofs.conditions.prescribed_dofs[d];
    summary.reactions_n[dofs.prescribed_owner[d]].second[dof % 3] += solver.reaction_forces()[dof];
  }
  if (series) {
    summary.output_steps = series->num_steps();
    series->Close(true);
    io::WriteVtu(options.out_dir + "/final.vtu", mesh, &u, OutputFields(mesh, problem.material, u));
    WriteSummaryJson(options.out_dir + "/summary.json", summary, "complete");
    summary.output_files = options.out_dir + "/sim.xmf (+ sim.h5), " + options.out_dir + "/final.vtu, " +
                           options.out_dir + "/summary.json";
  }
  return summary;
}

}  // namespace

std::string SimSummary::Describe() const {
  char text[2048];
  int n = std::snprintf(
      text, sizeof text,
      "mesh: %d nodes, %d tets; %s precision, %d threads\n"
      "steps: %lld of %.4g ms (%d substep%s each), %.4g s simulated\n"
      "wall: %.3f s stepping, %.1f M tet-steps/s, real-time factor %.2f\n"
      "stability: dt/dt_cr = %.2f; %s\n"
      "max |u|: %.4f mm at node %d\n",
      nodes, tets, sim::ToString(precision).c_str(), threads, steps, dt_s * 1e3, substeps_per_step, substeps_per_step > 1 ? "s" : "",
      simulated_s, wall_s, tet_steps_per_s / 1e6, realtime_factor, dt_s / substeps_per_step / stability.dt_critical_s,
      stability.Describe().c_str(), max_displacement_m * 1e3, max_displacement_node);
  for (const auto& [name, r] : reactions_n) {
    n += std::snprintf(text + n, sizeof text - n, "reaction on '%s' (force of the support on the body): (%.5g, %.5g, %.5g) N\n",
                       name.c_str(), r.x(), r.y(), r.z());
  }
  if (!output_files.empty()) {
    std::snprintf(text + n, sizeof text - n, "output: %d steps in %s\n", output_steps, output_files.c_str());
  }
  return text;
}

SimSummary RunSimProblem(const io::SimProblem& problem, const sim::TetMesh& mesh, const SimRunOptions& options) {
  return problem.precision == sim::Precision::kFloat ? Run<float>(problem, mesh, options)
                                                      : Run<double>(problem, mesh, options);
}

std::vector<std::string> SimOutputNames() {
  return {"sim.xmf", "sim.xmf.tmp", "sim.h5", "final.vtu", "summary.json", "summary.json.tmp"};
}

}  // namespace dg::tools
