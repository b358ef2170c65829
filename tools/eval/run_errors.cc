#include "tools/eval/run_errors.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <yaml-cpp/yaml.h>

#include "io/h5_file.h"
#include "sim/error.h"
#include "stages/register/phase_tracker.h"

namespace dg::tools {
namespace {

template <typename T>
std::vector<T> Column(const io::H5Reader& file, const std::string& name, int* width = nullptr) {
  io::H5Shape shape;
  std::vector<T> values = file.Read<T>("/errors/" + name, &shape);
  if (width) *width = shape.size() == 2 ? static_cast<int>(shape[1]) : 1;
  return values;
}

// The live phase's and the constant shift's errors against the truth, from /phase.
void ReadPhaseErrors(const io::H5Reader& file, RunErrors* run) {
  if (!file.Has("/phase/true_phase")) return;
  io::H5Shape shape;
  const std::vector<double> live = file.Read<double>("/phase/phase", &shape);
  const std::vector<double> registered = file.Read<double>("/phase/registered_phase", &shape);
  const std::vector<double> truth = file.Read<double>("/phase/true_phase", &shape);
  const size_t rows = std::min({live.size(), registered.size(), truth.size()});
  for (size_t r = 0; r < rows; ++r) {
    run->phase_error_ms.push_back(std::abs(stages::PhaseDifference(live[r], truth[r])) * 1e3 * run->period_s);
    run->registered_phase_error_ms.push_back(std::abs(stages::PhaseDifference(registered[r], truth[r])) * 1e3 *
                                             run->period_s);
  }
}

// The errors over the first `rows` frames of the run's typical surface point
// (ErrorFigures::typical_*), and how many points were seen throughout.
std::vector<double> TypicalFeatureCourse(const RunErrors& run, size_t rows, int* candidates) {
  const int points = run.truth_surface_points;
  std::vector<std::pair<double, int>> rms_of_point;  // (RMS over the rows, point)
  for (int p = 0; p < points && !run.surface_mm.empty(); ++p) {
    double squares = 0;
    bool seen_throughout = rows > 0;
    for (size_t r = 0; r < rows && seen_throughout; ++r) {
      const double e = run.surface_mm[r * points + p];
      seen_throughout = !std::isnan(e);
      squares += e * e;
    }
    if (seen_throughout) rms_of_point.emplace_back(std::sqrt(squares / rows), p);
  }
  *candidates = static_cast<int>(rms_of_point.size());
  if (rms_of_point.empty()) return {};
  const auto median = rms_of_point.begin() + rms_of_point.size() / 2;
  std::nth_element(rms_of_point.begin(), median, rms_of_point.end());
  std::vector<double> course(rows);
  for (size_t r = 0; r < rows; ++r) course[r] = run.surface_mm[r * points + median->second];
  return course;
}

// Errors pooled over rows: the average and RMS weighed (a surface row by its
// point count, an internal point once), and the largest.
struct Pool {
  int rows = 0;
  double weight = 0, sum = 0, squares = 0, largest = 0;

  void Add(double w, double mean, double rms, double max) {
    weight += w;
    sum += w * mean;
    squares += w * rms * rms;
    largest = std::max(largest, max);
  }
  void AddSurfaceRow(const RunErrors& run, size_t r) {
    ++rows;
    Add(run.surface_points[r], run.surface_mean_mm[r], run.surface_rms_mm[r], run.surface_max_mm[r]);
  }
  void AddInternalRow(const RunErrors& run, size_t r) {
    ++rows;
    for (int p = 0; p < run.internal_points; ++p) {
      const double e = run.internal_mm[r * run.internal_points + p];
      Add(1, e, e, e);
    }
  }
  // no_rows: the figures over no rows (0 for an empty window; NaN for a layer never shown, which has none).
  void Write(double no_rows, double* avg, double* max, double* rms) const {
    *avg = rows == 0 ? no_rows : weight > 0 ? sum / weight : 0;
    *rms = rows == 0 ? no_rows : weight > 0 ? std::sqrt(squares / weight) : 0;
    *max = rows == 0 ? no_rows : largest;
  }
};

// Whether row r was composed with the layer whose ages these are, drawn from the row's own state.
bool Shown(const std::vector<std::int64_t>& layer_age_frames, size_t r) {
  return r < layer_age_frames.size() && layer_age_frames[r] == 0;
}

}  // namespace

RunErrors ReadRunErrors(const std::string& run_h5) {
  const io::H5Reader file(run_h5);
  if (!file.Has("/errors/frame") || !file.Has("/registration")) {
    throw Error("the run log has no /errors or /registration", run_h5,
                "evaluate runs of a scene with ground truth (truth:) and a simulation (simulation:)");
  }
  RunErrors run;
  run.path = run_h5;
  const YAML::Node scene = YAML::Load(file.ReadString("/scene"));
  run.scene_name = scene["name"] ? scene["name"].as<std::string>() : "";
  if (scene["simulation"]["mode"]) {
    run.mode =
        sim::ParseSimulationMode(scene["simulation"]["mode"].as<std::string>(), run_h5 + ": /scene simulation.mode");
  }
  if (file.HasAttribute("/", "policy")) run.policy = file.ReadAttribute<std::string>("/", "policy");
  run.fps = file.ReadAttribute<double>("/", "fps");
  run.complete = file.ReadAttribute<std::int64_t>("/", "complete") == 1;
  const double wall_s = file.HasAttribute("/", "wall_s") ? file.ReadAttribute<double>("/", "wall_s") : 0;
  const auto frames = file.HasAttribute("/", "frames") ? file.ReadAttribute<std::int64_t>("/", "frames") : 0;
  run.realtime_factor = wall_s > 0 ? frames / run.fps / wall_s : 0;
  run.period_s = file.ReadScalar("/registration/period_s");
  run.residual_mm_left = file.ReadScalar("/registration/left/mean_mm");
  run.residual_mm_right = file.ReadScalar("/registration/right/mean_mm");
  run.registration_given = file.ReadAttribute<std::int64_t>("/registration", "frame") < 0;

  run.frame = Column<std::int64_t>(file, "frame");
  run.t_s = Column<double>(file, "t_s");
  run.surface_points = Column<std::int32_t>(file, "surface_points");
  run.surface_mean_mm = Column<double>(file, "surface_mean_mm");
  run.surface_rms_mm = Column<double>(file, "surface_rms_mm");
  run.surface_max_mm = Column<double>(file, "surface_max_mm");
  if (file.Has("/errors/surface_layer_age_frames")) {
    run.surface_layer_age_frames = Column<std::int64_t>(file, "surface_layer_age_frames");
    run.internal_layer_age_frames = Column<std::int64_t>(file, "internal_layer_age_frames");
  }
  if (file.Has("/errors/surface_mm")) run.surface_mm = Column<double>(file, "surface_mm", &run.truth_surface_points);
  run.internal_mm = Column<double>(file, "internal_mm", &run.internal_points);
  run.fiducial_sim_mm = Column<double>(file, "fiducial_sim_mm", &run.fiducials);
  run.fiducial_model_mm = Column<double>(file, "fiducial_model_mm");
  // A run killed inside a flush may leave columns of unequal length: the rows all columns have.
  const size_t rows = std::min({run.frame.size(), run.t_s.size(), run.surface_points.size(),
                                run.surface_mean_mm.size(), run.surface_rms_mm.size(), run.surface_max_mm.size(),
                                run.internal_mm.size() / std::max(1, run.internal_points),
                                run.fiducial_sim_mm.size() / std::max(1, run.fiducials),
                                run.fiducial_model_mm.size() / std::max(1, run.fiducials),
                                run.surface_mm.empty() ? run.frame.size()
                                                       : run.surface_mm.size() / std::max(1, run.truth_surface_points),
                                run.surface_layer_age_frames.empty() ? run.frame.size()
                                                                     : std::min(run.surface_layer_age_frames.size(),
                                                                                run.internal_layer_age_frames.size())});
  run.frame.resize(rows);
  run.t_s.resize(rows);
  run.surface_points.resize(rows);
  run.surface_mean_mm.resize(rows);
  run.surface_rms_mm.resize(rows);
  run.surface_max_mm.resize(rows);
  if (!run.surface_mm.empty()) run.surface_mm.resize(rows * run.truth_surface_points);
  if (!run.surface_layer_age_frames.empty()) {
    run.surface_layer_age_frames.resize(rows);
    run.internal_layer_age_frames.resize(rows);
  }
  run.internal_mm.resize(rows * run.internal_points);
  run.fiducial_sim_mm.resize(rows * run.fiducials);
  run.fiducial_model_mm.resize(rows * run.fiducials);
  ReadPhaseErrors(file, &run);
  return run;
}

size_t WindowRows(const RunErrors& run, int frames) {
  if (frames < 0 || run.frame.empty()) return run.frame.size();
  const std::int64_t end = run.frame.front() + frames;
  return std::partition_point(run.frame.begin(), run.frame.end(), [end](std::int64_t f) { return f < end; }) -
         run.frame.begin();
}

double StudyInternalRmsMm(const ErrorFigures& figures) {
  return std::isnan(figures.shown_internal_rms_mm) ? figures.internal_rms_mm : figures.shown_internal_rms_mm;
}

ErrorFigures Figures(const std::vector<const RunErrors*>& runs, int frames) {
  ErrorFigures figures;
  Pool surface, internal, shown_surface, shown_internal;
  int rows_with_ages = 0;
  std::vector<double> fiducial_sim, fiducial_model;
  double fiducial_rows = 0;
  std::vector<double> typical_course;
  for (const RunErrors* run : runs) {
    if (run == runs.front()) {
      fiducial_sim.assign(run->fiducials, 0.0);
      fiducial_model.assign(run->fiducials, 0.0);
    }
    if (run->fiducials != static_cast<int>(fiducial_sim.size())) {
      throw Error("runs with different fiducial counts cannot be pooled", run->path, "evaluate one phantom design");
    }
    const size_t rows = WindowRows(*run, frames);
    int candidates = 0;
    const std::vector<double> course = TypicalFeatureCourse(*run, rows, &candidates);
    typical_course.insert(typical_course.end(), course.begin(), course.end());
    figures.typical_points += candidates;
    if (!run->surface_layer_age_frames.empty()) rows_with_ages += static_cast<int>(rows);
    for (size_t r = 0; r < rows; ++r) {
      ++figures.frames;
      surface.AddSurfaceRow(*run, r);
      internal.AddInternalRow(*run, r);
      const bool surface_shown = Shown(run->surface_layer_age_frames, r);
      const bool internal_shown = Shown(run->internal_layer_age_frames, r);
      if (surface_shown) shown_surface.AddSurfaceRow(*run, r);
      if (internal_shown) shown_internal.AddInternalRow(*run, r);
      figures.shown_frames += surface_shown && internal_shown;
      for (int i = 0; i < run->fiducials; ++i) {
        fiducial_sim[i] += run->fiducial_sim_mm[r * run->fiducials + i];
        fiducial_model[i] += run->fiducial_model_mm[r * run->fiducials + i];
      }
      ++fiducial_rows;
    }
    for (size_t r = 0; r < run->phase_error_ms.size(); ++r) {
      ++figures.phase_frames;
      figures.phase_error_mean_ms += run->phase_error_ms[r];
      figures.phase_error_max_ms = std::max(figures.phase_error_max_ms, run->phase_error_ms[r]);
      figures.registered_phase_error_mean_ms += run->registered_phase_error_ms[r];
      figures.registered_phase_error_max_ms =
          std::max(figures.registered_phase_error_max_ms, run->registered_phase_error_ms[r]);
    }
  }
  if (figures.phase_frames > 0) {
    figures.phase_error_mean_ms /= figures.phase_frames;
    figures.registered_phase_error_mean_ms /= figures.phase_frames;
  }
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  surface.Write(0, &figures.surface_avg_mm, &figures.surface_max_mm, &figures.surface_rms_mm);
  internal.Write(0, &figures.internal_avg_mm, &figures.internal_max_mm, &figures.internal_rms_mm);
  shown_surface.Write(kNaN, &figures.shown_surface_avg_mm, &figures.shown_surface_max_mm,
                      &figures.shown_surface_rms_mm);
  shown_internal.Write(kNaN, &figures.shown_internal_avg_mm, &figures.shown_internal_max_mm,
                       &figures.shown_internal_rms_mm);
  figures.layer_present_fraction =
      rows_with_ages > 0 ? static_cast<double>(figures.shown_frames) / rows_with_ages : kNaN;
  if (typical_course.empty()) figures.typical_avg_mm = figures.typical_max_mm = figures.typical_rms_mm = kNaN;
  for (double e : typical_course) {
    figures.typical_avg_mm += e / typical_course.size();
    figures.typical_max_mm = std::max(figures.typical_max_mm, e);
    figures.typical_rms_mm += e * e / typical_course.size();
  }
  figures.typical_rms_mm = std::sqrt(figures.typical_rms_mm);
  for (size_t i = 0; i < fiducial_sim.size() && fiducial_rows > 0; ++i) {
    figures.fiducial_sim_avg_mm.push_back(fiducial_sim[i] / fiducial_rows);
    figures.fiducial_model_avg_mm.push_back(fiducial_model[i] / fiducial_rows);
  }
  return figures;
}

}  // namespace dg::tools
