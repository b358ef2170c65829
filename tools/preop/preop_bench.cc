#include "tools/preop/preop_bench.h"

#include <cstdio>
#include <filesystem>
#include <limits>
#include <sstream>

#include <nlohmann/json.hpp>

#include "io/ct/displacement_field.h"
#include "io/h5_file.h"
#include "sim/error.h"
#include "stages/register/fiducial_motion.h"
#include "tools/bench/bench_json.h"
#include "tools/json_text.h"
#include "tools/phantom/phantom_cache.h"

namespace dg::tools::preop {
namespace fs = std::filesystem;

PreopMotionErrors EvaluatePreopMotion(const std::string& out_dir, const std::string& phantom_dir) {
  PreopMotionErrors errors;
  const io::H5Reader scan(out_dir + "/scan.h5");
  io::H5Shape shape;
  const std::vector<double> nodes = scan.Read<double>("/nodes_S_m", &shape);
  const size_t N = shape[0];
  const std::vector<double> displacement = scan.Read<double>("/phases/node_displacement_m", &shape);
  const size_t P = shape[0];
  double sum = 0;
  size_t count = 0;
  for (size_t k = 1; k < P; ++k) {
    char name[64];
    std::snprintf(name, sizeof name, "truth/dvf_phase_%02zu.mha", k);
    const io::DisplacementField truth = io::ReadDisplacementField((fs::path(phantom_dir) / name).string());
    for (size_t a = 0; a < N; ++a) {
      const Eigen::Map<const Eigen::Vector3d> X_m(&nodes[3 * a]);
      if (!truth.Contains(X_m)) {  // an organ cut by the field of view: its surface lies beyond the last voxel centres
        if (k == 1) ++errors.nodes_outside_truth;
        continue;
      }
      const Eigen::Vector3d recovered = 1e3 * Eigen::Map<const Eigen::Vector3d>(&displacement[3 * (k * N + a)]);
      const double error = (recovered - truth.SampleMm(X_m)).norm();
      sum += error;
      ++count;
      errors.node_error_max_mm = std::max(errors.node_error_max_mm, error);
    }
  }
  errors.node_error_mean_mm = count ? sum / count : 0;

  // A phantom warped from a real CT (phantom --ct) has no fiducials, nor a scan without beads.
  const fs::path truth_scan = fs::path(phantom_dir) / "scan.h5";
  if (!fs::exists(truth_scan) || !scan.Has("/phases/fiducials_deformed_S_m")) {
    errors.fiducial_deformed_mean_mm = errors.fiducial_found_mean_mm = std::numeric_limits<double>::quiet_NaN();
    return errors;
  }
  const stages::FiducialMotion truth = stages::ReadFiducialMotion(truth_scan.string());
  const std::vector<double> deformed = scan.Read<double>("/phases/fiducials_deformed_S_m", &shape);
  const stages::FiducialMotion found = stages::ReadFiducialMotion(out_dir + "/scan.h5");
  const size_t F = shape[1];
  double deformed_sum = 0, found_sum = 0;
  for (size_t k = 0; k < P; ++k) {
    for (size_t f = 0; f < F; ++f) {
      const Eigen::Vector3d pushed = Eigen::Map<const Eigen::Vector3d>(&deformed[3 * (k * F + f)]);
      deformed_sum += (pushed - truth.positions_S_m[k].col(f)).norm();
      found_sum += (found.positions_S_m[k].col(f) - truth.positions_S_m[k].col(f)).norm();
    }
  }
  errors.fiducial_deformed_mean_mm = 1e3 * deformed_sum / double(P * F);
  errors.fiducial_found_mean_mm = 1e3 * found_sum / double(P * F);
  return errors;
}

PreopBenchRecord RunPreopBench(const std::string& out_dir, int threads, bool progress) {
  const std::string scene = DefaultScenePath(progress);
  const fs::path phantom = fs::path(scene).parent_path();
  PreopOptions options;
  options.ct_inputs = {(phantom / "ct" / "dicom").string()};
  options.out_dir = out_dir;
  options.like_scene = scene;
  options.threads = threads;
  options.progress = progress;
  PreopBenchRecord record;
  record.threads = threads;
  record.out_dir = out_dir;
  record.summary = RunPreop(options);

  record.errors = EvaluatePreopMotion(out_dir, phantom.string());
  return record;
}

void WritePreopBenchJson(const std::string& path, const PreopBenchRecord& r) {
  nlohmann::ordered_json steps = nlohmann::ordered_json::object();
  for (const StepTime& step : r.summary.steps) steps[step.step] = Decimals(step.wall_s, 3);
  const nlohmann::ordered_json record = {
      {"bench", "preop"},
      {"input", "default phantom, DICOM, " + std::to_string(r.summary.phases) + " phases"},
      {"threads", r.threads},
      {"wall_s", Decimals(r.summary.wall_s, 2)},
      {"steps_s", steps},
      {"tets", r.summary.mesh.tets},
      {"min_radius_ratio", Decimals(r.summary.mesh.min_radius_ratio, 3)},
      {"node_error_mean_mm", Decimals(r.errors.node_error_mean_mm, 4)},
      {"node_error_max_mm", Decimals(r.errors.node_error_max_mm, 4)},
      {"fiducial_deformed_mean_mm", Decimals(r.errors.fiducial_deformed_mean_mm, 4)},
      {"fiducial_found_mean_mm", Decimals(r.errors.fiducial_found_mean_mm, 4)}};
  WriteBenchJson(path, {JsonText(record, -1)});
}

std::string PreopBenchTable(const PreopBenchRecord& r) {
  std::ostringstream text;
  text << r.summary.Describe();
  text << Printed("recovered motion at the %d nodes against the phantom's exact field: mean %.3f mm, max %.3f mm\n",
                  r.summary.mesh.nodes, r.errors.node_error_mean_mm, r.errors.node_error_max_mm);
  text << Printed("fiducials against the phantom's: deformed %.3f mm, found in the CT %.3f mm on average\n",
                  r.errors.fiducial_deformed_mean_mm, r.errors.fiducial_found_mean_mm);
  text << "scene: " << r.out_dir << "/scene.yaml\n";
  return text.str();
}

}  // namespace dg::tools::preop
