#include "tools/preop/preop_report.h"

#include <fstream>
#include <sstream>

#include "sim/error.h"
#include "tools/json_text.h"

namespace dg::tools::preop {
namespace {

std::string JsonList(const std::vector<std::string>& items) {
  std::string list = "[";
  for (size_t i = 0; i < items.size(); ++i) list += (i ? ", " : "") + JsonQuoted(items[i]);
  return list + "]";
}

}  // namespace

PreopReportFile::PreopReportFile(std::string path, const PreopOptions& options) : path_(std::move(path)) {
  std::ostringstream inputs;
  inputs << "{\"ct\": " << JsonList(options.ct_inputs) << ", \"series_uids\": " << JsonList(options.series_uids)
         << ", \"label_map\": " << JsonQuoted(options.label_map) << ", \"like\": " << JsonQuoted(options.like_scene)
         << ", \"target_tets\": " << options.mesh.target_tets
         << ", \"grid_spacing_mm\": " << options.motion.grid_spacing_mm << ", \"levels\": " << options.motion.levels
         << "}";
  inputs_json_ = inputs.str();
  Write({}, false, {});
}

void PreopReportFile::Write(const PreopSummary& summary, bool complete, const std::string& error) {
  std::ostringstream json;
  json.precision(6);
  json << "{\n  \"complete\": " << (complete ? "true" : "false") << ",\n";
  if (!error.empty()) json << "  \"error\": " << JsonQuoted(error) << ",\n";
  json << "  \"inputs\": " << inputs_json_ << ",\n";
  json << "  \"wall_s\": " << summary.wall_s << ",\n  \"steps\": {";
  for (size_t s = 0; s < summary.steps.size(); ++s) {
    json << (s ? ", " : "") << JsonQuoted(summary.steps[s].step) << ": " << summary.steps[s].wall_s;
  }
  json << "},\n";
  json << "  \"ct\": {\"phases\": " << summary.phases << ", \"size\": [" << summary.ct_size.x() << ", "
       << summary.ct_size.y() << ", " << summary.ct_size.z() << "], \"spacing_mm\": [" << 1e3 * summary.ct_spacing_m.x()
       << ", " << 1e3 * summary.ct_spacing_m.y() << ", " << 1e3 * summary.ct_spacing_m.z() << "]},\n";
  const auto& seg = summary.segmentation;
  json << "  \"segmentation\": {\"organ_voxels\": " << seg.organ_voxels << ", \"mount_voxels\": " << seg.mount_voxels
       << ", \"internal_structures\": " << seg.internal_voxels.size()
       << ", \"organ_voxels_dropped\": " << seg.organ_voxels_dropped << "},\n";
  json << "  \"surface\": {\"extracted_triangles\": " << summary.surface.extracted_triangles
       << ", \"triangles\": " << summary.surface.triangles << "},\n";
  const auto& mesh = summary.mesh;
  json << "  \"mesh\": {\"nodes\": " << mesh.nodes << ", \"tets\": " << mesh.tets
       << ", \"surface_nodes\": " << mesh.surface_nodes << ", \"base_nodes\": " << mesh.base_nodes
       << ", \"volume_mm3\": " << 1e9 * mesh.volume_m3 << ", \"min_radius_ratio\": " << mesh.min_radius_ratio
       << ", \"mean_radius_ratio\": " << mesh.mean_radius_ratio << "},\n";
  json << "  \"registration\": [";
  for (size_t k = 0; k < summary.registration.size(); ++k) {
    const auto& phase = summary.registration[k];
    json << (k ? ",\n    " : "\n    ") << "{\"phase\": " << phase.phase << ", \"metric_before\": " << phase.metric_before
         << ", \"metric_after\": " << phase.metric_after << ", \"iterations\": " << phase.iterations << ", \"evaluations\": " << phase.evaluations
         << ", \"min_jacobian\": " << phase.min_jacobian << ", \"max_jacobian\": " << phase.max_jacobian
         << ", \"wall_s\": " << phase.wall_s << "}";
  }
  json << "],\n";
  const Eigen::MatrixXd& errors = summary.fiducials.error_m;
  json << "  \"fiducials\": {\"deformed_vs_found_mean_mm\": " << 1e3 * summary.fiducials.mean_m()
       << ", \"per_fiducial_mean_mm\": [";
  for (Eigen::Index f = 0; f < errors.cols(); ++f) json << (f ? ", " : "") << 1e3 * errors.col(f).mean();
  json << "], \"max_mm\": " << (errors.size() ? 1e3 * errors.maxCoeff() : 0.0) << "}\n}\n";
  std::ofstream file(path_);
  file << json.str();
  if (!file) throw Error("cannot write the report", path_, "check the folder's permissions and free space");
}

}  // namespace dg::tools::preop
