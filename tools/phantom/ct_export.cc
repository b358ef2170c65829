#include "tools/phantom/ct_export.h"

#include <cstdio>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>


namespace dg::tools::phantom {
namespace {

// What makes one phantom's CT differ from another's: the study's UIDs derive
// from it, so two different phantoms never share a study UID and the same
// phantom always writes the same one.
std::string CtIdentity(const PhantomSpec& spec) {
  char text[512];
  std::snprintf(text, sizeof text,
                "dynaguide phantom %s seed %llu: semi-axes %.9g %.9g %.9g, centre %.9g, motion %.9g %.9g %.9g "
                "%.9g %.9g, %.9g bpm, %d phases, voxel %.9g, noise %.9g, %d fiducials",
                spec.preset.c_str(), static_cast<unsigned long long>(spec.seed), spec.semi_axes_m.x(),
                spec.semi_axes_m.y(), spec.semi_axes_m.z(), spec.centre_height_m, spec.radial_contraction,
                spec.twist_rad, spec.longitudinal_shortening, spec.sway_m.x(), spec.sway_m.y(), spec.heart_rate_bpm,
                spec.phases, spec.voxel_m, spec.ct_noise_hu, spec.fiducials);
  return text;
}

}  // namespace

io::DicomSeriesInfo PhaseSeriesInfo(const std::string& identity, int phase, int phases,
                                    std::optional<double> heart_rate_bpm) {
  io::DicomSeriesInfo info;
  info.study_uid = io::DeterministicUid(identity + ", study");
  info.series_uid = io::DeterministicUid(identity + ", series of phase " + std::to_string(phase));
  info.frame_of_reference_uid = io::DeterministicUid(identity + ", frame of reference");
  info.date = "20000101";  // a fixed date: the same identity writes the same bytes
  const double fraction = double(phase) / phases;
  char description[64];
  std::snprintf(description, sizeof description, "phase %02d (%.4g%%)", phase, 100 * fraction);
  info.series_description = description;
  info.series_number = phase + 1;
  info.temporal_position = phase + 1;
  info.temporal_positions = phases;
  info.cycle_fraction = fraction;
  if (heart_rate_bpm) {  // HeartRate and TriggerTime are the cardiac gating's tags
    info.trigger_time_ms = 1e3 * (60 / *heart_rate_bpm) * fraction;
    info.heart_rate_bpm = *heart_rate_bpm;
  }
  return info;
}

void WriteDicomPhase(const io::VolumeI16& volume, const PhantomSpec& spec, int phase, const std::string& folder) {
  io::DicomSeriesInfo info = PhaseSeriesInfo(CtIdentity(spec), phase, spec.phases, spec.heart_rate_bpm);
  info.patient_id = "DG-PHANTOM-" + spec.preset + "-" + std::to_string(spec.seed);
  info.patient_name = "Phantom^" + spec.preset;
  info.study_description = "dynaguide phantom 4D CT";
  io::WriteDicomSeries(io::ToCtImage(volume, ""), folder, info);
}

io::DisplacementField PhaseDisplacementField(const io::VolumeI16& grid, const HeartMotion& motion,
                                             const MotionState& first, const MotionState& phase) {
  io::DisplacementField field;
  field.size = grid.size;
  field.spacing_m = grid.spacing_m;
  field.origin_m = grid.origin_m;
  field.u_mm.resize(3, static_cast<Eigen::Index>(grid.num_voxels()));
  tbb::parallel_for(tbb::blocked_range<int>(0, grid.size.z()), [&](const tbb::blocked_range<int>& slices) {
    for (int k = slices.begin(); k != slices.end(); ++k) {
      for (int j = 0; j < grid.size.y(); ++j) {
        for (int i = 0; i < grid.size.x(); ++i) {
          const Eigen::Vector3d X = field.PointOf(i, j, k);
          const Eigen::Vector3d x = motion.Deform(motion.Undeform(X, first), phase);
          field.u_mm.col(static_cast<Eigen::Index>(field.Index(i, j, k))) = (1e3 * (x - X)).cast<float>();
        }
      }
    }
  });
  return field;
}

}  // namespace dg::tools::phantom
