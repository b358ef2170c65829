#include "pipeline/error_log.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "io/h5_file.h"
#include "io/registration_file.h"
#include "sim/error.h"
#include "stages/fem_stage.h"
#include "stages/overlay/overlay_error.h"

namespace dg::pipeline {
namespace {

struct Moments {
  double mean = 0, rms = 0, max = 0;
};

Moments MomentsOf(const std::vector<double>& values) {
  Moments m;
  for (double v : values) {
    m.mean += v;
    m.rms += v * v;
    m.max = std::max(m.max, v);
  }
  if (!values.empty()) {
    m.mean /= values.size();
    m.rms = std::sqrt(m.rms / values.size());
  }
  return m;
}

std::vector<io::H5Column> ErrorColumns(int surface_points, int internal_points, int fiducials) {
  using io::H5Type;
  std::vector<io::H5Column> columns = {{"frame", H5Type::kInt64}, {"t_s", H5Type::kDouble},
                                       {"surface_points", H5Type::kInt32}};
  for (const char* name : {"surface_mean_px", "surface_rms_px", "surface_max_px", "surface_mean_mm", "surface_rms_mm",
                           "surface_max_mm", "internal_mean_mm", "internal_rms_mm", "internal_max_mm"}) {
    columns.push_back({name, H5Type::kDouble});
  }
  // The overlay as composed: the layer's age, and the figures as the layer shows them (NaN without a layer).
  for (const char* name : {"surface_layer_age_frames", "internal_layer_age_frames"}) {
    columns.push_back({name, H5Type::kInt64});
  }
  for (const char* name : {"shown_surface_mean_px", "shown_surface_rms_px", "shown_surface_max_px",
                           "shown_surface_mean_mm", "shown_surface_rms_mm", "shown_surface_max_mm",
                           "shown_internal_mean_mm", "shown_internal_rms_mm", "shown_internal_max_mm"}) {
    columns.push_back({name, H5Type::kDouble});
  }
  // A zero-width column is not allowed: one zero stands in for none.
  columns.push_back({"surface_mm", H5Type::kDouble, static_cast<std::size_t>(std::max(1, surface_points))});
  columns.push_back({"internal_mm", H5Type::kDouble, static_cast<std::size_t>(std::max(1, internal_points))});
  columns.push_back({"fiducial_sim_mm", H5Type::kDouble, static_cast<std::size_t>(std::max(1, fiducials))});
  columns.push_back({"fiducial_model_mm", H5Type::kDouble, static_cast<std::size_t>(std::max(1, fiducials))});
  return columns;
}

}  // namespace

ErrorLog::Truth ErrorLog::ReadTruth(const std::string& truth_h5) {
  const io::H5Reader file(truth_h5);
  Truth truth;
  truth.path = truth_h5;
  for (auto [group, points] : {std::pair{"surface_points", &truth.surface}, std::pair{"internal_points", &truth.internal},
                               std::pair{"fiducials", &truth.fiducials}}) {
    const std::string prefix = std::string("/") + group;
    points->reference_S = file.ReadMatrix(prefix + "/X_S_m").transpose();
    points->count = static_cast<int>(points->reference_S.cols());
    io::H5Shape shape;
    points->xyz_C = file.Read<double>(prefix + "/xyz_C_m", &shape);
    if (shape.size() != 3 || shape[1] != size_t(points->count) || shape[2] != 3) {
      throw Error(prefix + "/xyz_C_m does not hold frames x " + std::to_string(points->count) + " x 3 positions",
                  truth_h5, "use the truth file `dynaguide phantom` wrote with the scene");
    }
    truth.frames = static_cast<int>(shape[0]);
  }
  truth.surface_uv = file.Read<double>("/surface_points/uv_left_px");
  truth.surface_visible = file.Read<std::uint8_t>("/surface_points/visible_left");
  const size_t rows = size_t(truth.frames) * truth.surface.count;
  if (truth.surface_uv.size() != 2 * rows || truth.surface_visible.size() != rows ||
      truth.internal.xyz_C.size() != 3 * size_t(truth.frames) * truth.internal.count ||
      truth.fiducials.xyz_C.size() != 3 * size_t(truth.frames) * truth.fiducials.count) {
    throw Error("the surface and internal points' datasets cover different frames", truth_h5,
                "use the truth file `dynaguide phantom` wrote with the scene");
  }
  return truth;
}

namespace {

// The index of the first of `wanted` among the overlays, or -1.
int OverlayIndex(const std::vector<std::string>& names, std::initializer_list<const char*> wanted) {
  for (const char* name : wanted) {
    const auto found = std::find(names.begin(), names.end(), name);
    if (found != names.end()) return static_cast<int>(found - names.begin());
  }
  return -1;
}

}  // namespace

ErrorLog::ErrorLog(io::RunLog& log, const std::string& truth_h5, const sim::TetMesh& mesh,
                   const io::CameraCalibration& left, stages::FiducialMotion scan,
                   const std::vector<std::string>& overlay_names)
    : surface_layer_(OverlayIndex(overlay_names, {"texture"})),
      internal_layer_(OverlayIndex(overlay_names, {"meshes", "volume"})),
      truth_(ReadTruth(truth_h5)),
      table_(log.AddTable("/errors", ErrorColumns(truth_.surface.count, truth_.internal.count, truth_.fiducials.count))),
      left_(left),
      scan_(std::move(scan)),
      surface_embedding_(mesh, truth_.surface.reference_S),
      internal_embedding_(mesh, truth_.internal.reference_S),
      fiducial_embedding_(mesh, truth_.fiducials.reference_S) {
  if (scan_.num_phases() > 0 && scan_.num_fiducials() != truth_.fiducials.count) {
    throw Error("the scan has " + std::to_string(scan_.num_fiducials()) + " fiducials, the truth " +
                    std::to_string(truth_.fiducials.count),
                truth_h5, "use the truth recorded with the scene's scan");
  }
}

void ErrorLog::Consume(const FramePacket& packet) {
  if (!packet.simulation || !packet.registration) return;
  if (packet.index >= truth_.frames) {
    throw Error("frame " + std::to_string(packet.index) + " is beyond the truth's " + std::to_string(truth_.frames) +
                    " frames",
                truth_.path, "use the truth recorded with this video");
  }
  const Eigen::Isometry3d T_C_S(packet.registration->T_C_S);
  const Eigen::Matrix3Xd& nodes_S = packet.simulation->nodes_S_m;
  const size_t frame = static_cast<size_t>(packet.index);

  const int S = truth_.surface.count;
  const Eigen::Matrix3Xd drawn_C = T_C_S * surface_embedding_.Rebuild(nodes_S);
  const Eigen::Matrix2Xd true_uv = Eigen::Map<const Eigen::Matrix2Xd>(&truth_.surface_uv[2 * frame * S], 2, S);
  const Eigen::Matrix3Xd true_C = Eigen::Map<const Eigen::Matrix3Xd>(&truth_.surface.xyz_C[3 * frame * S], 3, S);
  const std::vector<std::uint8_t> visible(truth_.surface_visible.begin() + frame * S,
                                          truth_.surface_visible.begin() + (frame + 1) * S);
  const stages::overlay::SurfaceOverlayError surface =
      stages::overlay::MeasureSurfaceOverlayError(left_, drawn_C, true_uv, true_C, visible);
  const Moments px = MomentsOf(surface.error_px), mm = MomentsOf(surface.error_mm);
  // Per point, NaN where the left camera does not see it: a point's course
  // through a window (the paper's "typical feature") and where the maximum
  // sits are read from it.
  std::vector<double> surface_mm(S, std::numeric_limits<double>::quiet_NaN());
  for (size_t k = 0; k < surface.points.size(); ++k) surface_mm[surface.points[k]] = surface.error_mm[k];

  const int I = truth_.internal.count;
  const Eigen::Matrix3Xd internal_C = T_C_S * internal_embedding_.Rebuild(nodes_S);
  std::vector<double> internal_mm = stages::overlay::InternalErrorMm(
      internal_C, Eigen::Map<const Eigen::Matrix3Xd>(&truth_.internal.xyz_C[3 * frame * I], 3, I));
  const Moments internal = MomentsOf(internal_mm);

  const int F = truth_.fiducials.count;
  const Eigen::Map<const Eigen::Matrix3Xd> true_fiducials_C(&truth_.fiducials.xyz_C[3 * frame * F], 3, F);
  std::vector<double> fiducial_sim_mm =
      stages::overlay::InternalErrorMm(T_C_S * fiducial_embedding_.Rebuild(nodes_S), true_fiducials_C);
  std::vector<double> fiducial_model_mm(F, 0.0);
  if (scan_.num_phases() > 0) {
    const double phase = (packet.t_s + packet.registration->phase_shift_s) / packet.registration->period_s;
    for (int i = 0; i < F; ++i) {
      Eigen::Vector3d model_S;
      stages::FiducialAtPhase(scan_, i, phase, model_S.data());
      fiducial_model_mm[i] = 1e3 * (T_C_S * model_S - true_fiducials_C.col(i)).norm();
    }
  }
  for (std::vector<double>* values : {&surface_mm, &internal_mm, &fiducial_sim_mm, &fiducial_model_mm}) {
    if (values->empty()) values->push_back(0);  // a zero-width column is not allowed: one zero stands in
  }

  // The overlay as composed: each layer is drawn from its frame's own state
  // (pipeline/overlay_stages.h), so where it was composed at age 0 it shows
  // the figures above; a frame composed without it shows nothing.
  const auto age = [&](int layer) -> std::int64_t {
    return layer >= 0 && static_cast<size_t>(layer) < packet.layer_age_frames.size() ? packet.layer_age_frames[layer]
                                                                                    : -1;
  };
  const std::int64_t surface_age = age(surface_layer_), internal_age = age(internal_layer_);
  DG_CHECK(surface_age <= 0 && internal_age <= 0);  // a layer of another frame's state would need that state here
  const double none = std::numeric_limits<double>::quiet_NaN();
  const auto shown = [none](std::int64_t layer_age, double value) { return layer_age == 0 ? value : none; };

  table_.AppendRow({packet.index, packet.t_s, static_cast<std::int32_t>(surface.points.size()), px.mean, px.rms,
                    px.max, mm.mean, mm.rms, mm.max, internal.mean, internal.rms, internal.max, surface_age,
                    internal_age, shown(surface_age, px.mean), shown(surface_age, px.rms), shown(surface_age, px.max),
                    shown(surface_age, mm.mean), shown(surface_age, mm.rms), shown(surface_age, mm.max),
                    shown(internal_age, internal.mean), shown(internal_age, internal.rms),
                    shown(internal_age, internal.max), surface_mm, internal_mm, fiducial_sim_mm, fiducial_model_mm});
}

}  // namespace dg::pipeline
