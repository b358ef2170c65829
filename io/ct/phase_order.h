#pragma once

#include <limits>
#include <string>
#include <vector>

namespace dg::io {

// The cardiac- and respiratory-phase tags of one phase's series, as its files carry them
// (NaN or 0 when absent). Plain data, so that the ordering rule below is
// tested without files.
struct PhaseTags {
  static constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  std::string where;                   // the folder or file, for messages
  std::string series_uid, description;
  double nominal_percentage = kNone;    // NominalPercentageOfCardiacPhase (0020,9241)
  double description_percentage = kNone;  // "40%" in SeriesDescription (0008,103E)
  int temporal_position = 0;           // TemporalPositionIdentifier (0020,0100), from 1
  int temporal_positions = 0;          // NumberOfTemporalPositions (0020,0105)
  double trigger_time_ms = kNone;      // TriggerTime (0018,1060), after the R wave
  double heart_rate_bpm = kNone;       // HeartRate (0018,1088)
  double respiratory_percentage = kNone;  // NominalPercentageOfRespiratoryPhase (0020,9245)
  double respiratory_delay_ms = kNone;    // NominalRespiratoryTriggerDelayTime (0020,9255), after the trigger
  double respiratory_interval_ms = kNone;  // RespiratoryIntervalTime (0020,9254): one breath
  double name_percentage = kNone;      // "50%" in the file's or folder's own name (where)

  std::string Describe() const;  // "UID 'description' (40%, temporal position 5)"
};

// The percentage a series description names ("phase 40%", "40.0 %", "T=50%",
// "Gated 50%"), or NaN.
double DescriptionPercentage(const std::string& description);

// The percentage in the last component of a path ("ct_50%.nii.gz",
// "phase 40%/"), or NaN.
double NamePercentage(const std::string& path);

// Which tag orders the phases: the first of these that every phase carries.
//   1. NominalPercentageOfCardiacPhase: the cardiac phase itself;
//   2. NominalPercentageOfRespiratoryPhase: the breathing phase itself;
//   3. a percentage in the series description (what most scanners write
//      when they leave out the tags above, cardiac or respiratory);
//   4. TemporalPositionIdentifier: an index 1..N of the cycle's phases;
//   5. TriggerTime: milliseconds after the R wave;
//   6. NominalRespiratoryTriggerDelayTime: milliseconds after the
//      respiratory trigger;
//   7. a percentage in the file's or folder's name (a file per phase).
// The percentages, the index (with NumberOfTemporalPositions) and the
// delays (with HeartRate, or RespiratoryIntervalTime) also give each
// phase's fraction of the cycle.
enum class PhaseKey {
  kNone,
  kNominalPercentage,
  kRespiratoryPercentage,
  kDescriptionPercentage,
  kTemporalPosition,
  kTriggerTime,
  kRespiratoryDelay,
  kNamePercentage,
};
const char* PhaseKeyName(PhaseKey key);
PhaseKey CommonPhaseKey(const std::vector<PhaseTags>& phases);

struct PhaseOrder {
  PhaseKey key = PhaseKey::kNone;
  std::vector<int> order;               // indices into the phases, in cycle order
  std::vector<double> cycle_fraction;   // per index in `order`, in [0, 1); NaN when the tags cannot tell
};

// Orders phases by CommonPhaseKey and, with require_whole_cycle, checks the cycle is whole:
// temporal positions must be 1..N (N from NumberOfTemporalPositions, else the
// largest); percentages and trigger times evenly spaced but for a gap of a
// whole number of steps are missing phases (percentages wrap around the
// cycle; an unevenly spaced set is taken as it is). With `given_order` the
// phases stay in the order given and the tags, when all carry one, must agree
// with it. Without a common key: given_order keeps the order, else an error.
// @throws dg::Error naming `where` for two phases at the same tag value, a
//   missing phase (which one), phases given out of cycle order, or phases
//   that cannot be ordered (listing each series' UID, description and tags).
PhaseOrder OrderPhases(const std::vector<PhaseTags>& phases, bool given_order, bool require_whole_cycle,
                       const std::string& where);

}  // namespace dg::io
