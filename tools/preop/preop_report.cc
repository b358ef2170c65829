#include "tools/preop/preop_report.h"

#include <fstream>

#include <nlohmann/json.hpp>

#include "sim/error.h"
#include "tools/json_text.h"

namespace dg::tools::preop {

using Json = nlohmann::ordered_json;

PreopReportFile::PreopReportFile(std::string path, const PreopOptions& options) : path_(std::move(path)) {
  const Json inputs = {{"ct", options.ct_inputs},
                       {"series_uids", options.series_uids},
                       {"label_map", options.label_map},
                       {"like", options.like_scene},
                       {"fiducials_file", options.fiducials_file},
                       {"bead_detection", options.beads.Describe()},
                       {"resume", options.resume},
                       {"target_tets", options.mesh.target_tets},
                       {"grid_spacing_mm", Significant(options.motion.grid_spacing_mm, 6)},
                       {"levels", options.motion.levels}};
  inputs_json_ = JsonText(inputs, -1);
  Write({}, false, {});
}

void PreopReportFile::Write(const PreopSummary& summary, bool complete, const std::string& error) {
  const auto figure = [](double value) { return Significant(value, 6); };
  const auto vector = [&](const auto& v, double scale) {
    return Json::array({figure(scale * v.x()), figure(scale * v.y()), figure(scale * v.z())});
  };
  Json json = {{"complete", complete}};
  if (!error.empty()) json["error"] = error;
  json["inputs"] = Json::parse(inputs_json_);
  json["wall_s"] = figure(summary.wall_s);
  json["peak_rss_gb"] = figure(summary.peak_rss_gb);
  Json steps = Json::object();
  for (const StepTime& step : summary.steps) steps[step.step] = figure(step.wall_s);
  json["steps"] = steps;
  json["ct"] = {{"phases", summary.phases},
                {"size", {summary.ct_size.x(), summary.ct_size.y(), summary.ct_size.z()}},
                {"spacing_mm", vector(summary.ct_spacing_m, 1e3)},
                {"reoriented_from", summary.ct_reoriented_from}};
  const auto& seg = summary.segmentation;
  json["segmentation"] = {{"organ_voxels", seg.organ_voxels},
                          {"mount_voxels", seg.mount_voxels},
                          {"internal_structures", seg.internal_voxels.size()},
                          {"organ_voxels_dropped", seg.organ_voxels_dropped},
                          {"organ_volume_ml", figure(seg.organ_volume_ml)},
                          {"organ_box_mm", {vector(seg.organ_min_mm, 1), vector(seg.organ_max_mm, 1)}},
                          {"organ_median_hu", figure(seg.organ_median_hu)},
                          {"label_image", "segmentation.nii.gz"}};
  json["surface"] = {{"tunnel_closing_mm", figure(summary.tunnel_closing_mm)},
                     {"smoothing_voxels", figure(summary.surface.image_smoothing_sigma_voxels)},
                     {"extracted_triangles", summary.surface.extracted_triangles},
                     {"triangles", summary.surface.triangles}};
  const auto& mesh = summary.mesh;
  json["mesh"] = {{"nodes", mesh.nodes},
                  {"tets", mesh.tets},
                  {"surface_nodes", mesh.surface_nodes},
                  {"base_nodes", mesh.base_nodes},
                  {"volume_mm3", figure(1e9 * mesh.volume_m3)},
                  {"min_radius_ratio", figure(mesh.min_radius_ratio)},
                  {"min_radius_ratio_meshed", figure(mesh.min_radius_ratio_meshed)},
                  {"optimisation_rounds", mesh.optimisation_rounds},
                  {"mean_radius_ratio", figure(mesh.mean_radius_ratio)}};
  json["stability"] = {{"dt_critical_ms", figure(1e3 * summary.stability.dt_critical_s)},
                       {"dt_ms", figure(1e3 * summary.stability.dt_s)},
                       {"safety", figure(summary.stability.safety)},
                       {"limit", summary.stability.limit}};
  Json registration = Json::array();
  for (const auto& phase : summary.registration) {
    registration.push_back({{"phase", phase.phase},
                            {"metric_before", figure(phase.metric_before)},
                            {"metric_after", figure(phase.metric_after)},
                            {"iterations", phase.iterations},
                            {"evaluations", phase.evaluations},
                            {"min_jacobian", figure(phase.min_jacobian)},
                            {"max_jacobian", figure(phase.max_jacobian)},
                            {"wall_s", figure(phase.wall_s)}});
  }
  json["registration"] = registration;
  json["registrations_from_cache"] = summary.phases_from_cache;
  const Eigen::MatrixXd& errors = summary.fiducials.error_m;
  Json per_fiducial = Json::array();
  for (Eigen::Index f = 0; f < errors.cols(); ++f) per_fiducial.push_back(figure(1e3 * errors.col(f).mean()));
  static constexpr const char* kSources[] = {"none", "beads", "file"};
  json["fiducials"] = {{"source", kSources[static_cast<int>(summary.fiducial_source)]},
                       {"count", summary.fiducial_count},
                       {"deformed_vs_found_mean_mm", figure(1e3 * summary.fiducials.mean_m())},
                       {"per_fiducial_mean_mm", per_fiducial},
                       {"max_mm", figure(errors.size() ? 1e3 * errors.maxCoeff() : 0.0)}};
  std::ofstream file(path_);
  file << JsonText(json);
  if (!file) throw Error("cannot write the report", path_, "check the folder's permissions and free space");
}

}  // namespace dg::tools::preop
