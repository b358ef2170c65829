#include "io/ct/phase_order.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <regex>
#include <set>

#include "sim/error.h"

namespace dg::io {
namespace {

std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

// The key's value of one phase, NaN when it does not carry it.
double KeyValue(const PhaseTags& phase, PhaseKey key) {
  switch (key) {
    case PhaseKey::kNominalPercentage: return phase.nominal_percentage;
    case PhaseKey::kRespiratoryPercentage: return phase.respiratory_percentage;
    case PhaseKey::kDescriptionPercentage: return phase.description_percentage;
    case PhaseKey::kNamePercentage: return phase.name_percentage;
    case PhaseKey::kRespiratoryDelay: return phase.respiratory_delay_ms;
    case PhaseKey::kTemporalPosition: return phase.temporal_position > 0 ? phase.temporal_position : PhaseTags::kNone;
    case PhaseKey::kTriggerTime: return phase.trigger_time_ms;
    case PhaseKey::kNone: break;
  }
  return PhaseTags::kNone;
}

std::string ValueText(double value, PhaseKey key) {
  switch (key) {
    case PhaseKey::kNominalPercentage:
    case PhaseKey::kRespiratoryPercentage:
    case PhaseKey::kDescriptionPercentage:
    case PhaseKey::kNamePercentage: return Number(value) + "%";
    case PhaseKey::kTemporalPosition: return "temporal position " + Number(value);
    case PhaseKey::kTriggerTime: return "trigger time " + Number(value) + " ms";
    case PhaseKey::kRespiratoryDelay: return "respiratory trigger delay " + Number(value) + " ms";
    case PhaseKey::kNone: break;
  }
  return "?";
}

double CycleFraction(const PhaseTags& phase, PhaseKey key) {
  const double value = KeyValue(phase, key);
  switch (key) {
    case PhaseKey::kNominalPercentage:
    case PhaseKey::kRespiratoryPercentage:
    case PhaseKey::kDescriptionPercentage:
    case PhaseKey::kNamePercentage: return std::fmod(value / 100, 1.0);
    case PhaseKey::kRespiratoryDelay:
      return phase.respiratory_interval_ms > 0 ? std::fmod(value / phase.respiratory_interval_ms, 1.0)
                                               : PhaseTags::kNone;
    case PhaseKey::kTemporalPosition:
      return phase.temporal_positions > 0 ? (value - 1) / phase.temporal_positions : PhaseTags::kNone;
    case PhaseKey::kTriggerTime:
      return phase.heart_rate_bpm > 0 ? std::fmod(value * phase.heart_rate_bpm / 60000, 1.0) : PhaseTags::kNone;
    case PhaseKey::kNone: break;
  }
  return PhaseTags::kNone;
}

// Values (sorted, distinct) evenly spaced by their smallest gap but for gaps of
// a whole number of steps: the values missing in those gaps. `period` closes
// the cycle (the gap from the last value round to the first); 0 for none.
// Unevenly spaced values are not judged: an empty list.
std::vector<double> MissingSteps(const std::vector<double>& sorted, double period) {
  std::vector<double> gaps;
  for (size_t i = 0; i + 1 < sorted.size(); ++i) gaps.push_back(sorted[i + 1] - sorted[i]);
  if (period > 0) gaps.push_back(sorted.front() + period - sorted.back());
  if (gaps.size() < 2) return {};
  const double step = *std::min_element(gaps.begin(), gaps.end());
  // Scanners round percentages and times: 0, 33, 67 are even steps of a third.
  constexpr double kTolerance = 0.1;
  for (double gap : gaps) {
    if (std::abs(gap / step - std::round(gap / step)) > kTolerance) return {};
  }
  std::vector<double> missing;
  for (size_t i = 0; i < gaps.size(); ++i) {
    const int steps = static_cast<int>(std::lround(gaps[i] / step));
    for (int m = 1; m < steps; ++m) {
      const double value = sorted[i] + m * gaps[i] / steps;
      missing.push_back(period > 0 ? std::fmod(value, period) : value);
    }
  }
  return missing;
}

std::string DescribeAll(const std::vector<PhaseTags>& phases) {
  std::string text;
  for (const PhaseTags& phase : phases) text += (text.empty() ? "" : "; ") + phase.Describe();
  return text;
}

void CheckWhole(const std::vector<PhaseTags>& phases, PhaseKey key, const std::vector<double>& sorted,
                const std::string& where) {
  std::vector<std::string> missing;
  if (key == PhaseKey::kTemporalPosition) {
    int count = static_cast<int>(sorted.back());
    for (const PhaseTags& phase : phases) count = std::max(count, phase.temporal_positions);
    const std::set<int> present(sorted.begin(), sorted.end());
    for (int t = 1; t <= count; ++t) {
      if (!present.count(t)) missing.push_back(Number(t));
    }
    if (!missing.empty()) {
      std::string list;
      for (const std::string& t : missing) list += (list.empty() ? "" : ", ") + t;
      throw Error("a phase is missing: temporal position " + list + " of 1.." + std::to_string(count) +
                      " is absent (present: " + DescribeAll(phases) + ")",
                  where, "add the missing phase's series, or select the phases you have by series UID");
    }
    return;
  }
  const bool percentage = key == PhaseKey::kNominalPercentage || key == PhaseKey::kRespiratoryPercentage ||
                          key == PhaseKey::kDescriptionPercentage || key == PhaseKey::kNamePercentage;
  for (double value : MissingSteps(sorted, percentage ? 100.0 : 0.0)) missing.push_back(ValueText(value, key));
  if (!missing.empty()) {
    std::string list;
    for (const std::string& m : missing) list += (list.empty() ? "" : ", ") + m;
    throw Error("a phase is missing: the phases are evenly spaced but for " + list + " (present: " +
                    DescribeAll(phases) + ")",
                where, "add the missing phase's series, or select the phases you have by series UID");
  }
}

}  // namespace

std::string PhaseTags::Describe() const {
  std::string text = series_uid.empty() ? where : series_uid;
  if (!description.empty()) text += " '" + description + "'";
  std::vector<std::string> tags;
  if (!std::isnan(nominal_percentage)) tags.push_back("nominal " + Number(nominal_percentage) + "%");
  if (!std::isnan(respiratory_percentage)) tags.push_back("respiratory " + Number(respiratory_percentage) + "%");
  if (temporal_position > 0) tags.push_back("temporal position " + std::to_string(temporal_position));
  if (!std::isnan(trigger_time_ms)) tags.push_back("trigger time " + Number(trigger_time_ms) + " ms");
  if (!std::isnan(respiratory_delay_ms)) {
    tags.push_back("respiratory trigger delay " + Number(respiratory_delay_ms) + " ms");
  }
  std::string list;
  for (const std::string& tag : tags) list += (list.empty() ? "" : ", ") + tag;
  return text + " (" + (list.empty() ? "no phase tag" : list) + ")";
}

double DescriptionPercentage(const std::string& description) {
  static const std::regex kPercentage(R"((\d+(?:\.\d+)?)\s*%)");
  std::smatch match;
  if (!std::regex_search(description, match, kPercentage)) return PhaseTags::kNone;
  return std::stod(match[1]);
}

double NamePercentage(const std::string& path) {
  std::string name = path;
  while (!name.empty() && name.back() == '/') name.pop_back();
  return DescriptionPercentage(name.substr(name.find_last_of('/') + 1));
}

const char* PhaseKeyName(PhaseKey key) {
  switch (key) {
    case PhaseKey::kNominalPercentage: return "NominalPercentageOfCardiacPhase (0020,9241)";
    case PhaseKey::kRespiratoryPercentage: return "NominalPercentageOfRespiratoryPhase (0020,9245)";
    case PhaseKey::kRespiratoryDelay: return "NominalRespiratoryTriggerDelayTime (0020,9255)";
    case PhaseKey::kNamePercentage: return "the percentage in the file or folder name";
    case PhaseKey::kDescriptionPercentage: return "the percentage in SeriesDescription (0008,103E)";
    case PhaseKey::kTemporalPosition: return "TemporalPositionIdentifier (0020,0100)";
    case PhaseKey::kTriggerTime: return "TriggerTime (0018,1060)";
    case PhaseKey::kNone: break;
  }
  return "no phase tag";
}

PhaseKey CommonPhaseKey(const std::vector<PhaseTags>& phases) {
  if (phases.empty()) return PhaseKey::kNone;
  for (PhaseKey key : {PhaseKey::kNominalPercentage, PhaseKey::kRespiratoryPercentage,
                       PhaseKey::kDescriptionPercentage, PhaseKey::kTemporalPosition, PhaseKey::kTriggerTime,
                       PhaseKey::kRespiratoryDelay, PhaseKey::kNamePercentage}) {
    if (std::all_of(phases.begin(), phases.end(),
                    [key](const PhaseTags& phase) { return !std::isnan(KeyValue(phase, key)); })) {
      return key;
    }
  }
  return PhaseKey::kNone;
}

PhaseOrder OrderPhases(const std::vector<PhaseTags>& phases, bool given_order, bool require_whole_cycle,
                       const std::string& where) {
  PhaseOrder result;
  result.key = CommonPhaseKey(phases);
  result.order.resize(phases.size());
  std::iota(result.order.begin(), result.order.end(), 0);
  if (result.key == PhaseKey::kNone) {
    if (!given_order && phases.size() > 1) {
      throw Error("the folder holds " + std::to_string(phases.size()) +
                      " series and they cannot be ordered as the phases of one cycle, since not all carry a "
                      "cardiac- or respiratory-phase tag: " + DescribeAll(phases),
                  where,
                  "select the phases by series UID in cycle order, or put each phase's series in a folder of its "
                  "own and give the folders in cycle order");
    }
    result.cycle_fraction.assign(phases.size(), PhaseTags::kNone);
    return result;
  }

  const PhaseKey key = result.key;
  auto value = [&](int i) { return KeyValue(phases[i], key); };
  if (given_order) {
    for (size_t i = 0; i + 1 < phases.size(); ++i) {
      if (!(value(i) < value(i + 1))) {
        throw Error("phases given out of cycle order: " + phases[i].where + " (" + ValueText(value(i), key) +
                        ") comes before " + phases[i + 1].where + " (" + ValueText(value(i + 1), key) + ")",
                    where, std::string("give the phases in ascending order of ") + PhaseKeyName(key));
      }
    }
  } else {
    std::stable_sort(result.order.begin(), result.order.end(), [&](int a, int b) { return value(a) < value(b); });
    for (size_t i = 0; i + 1 < result.order.size(); ++i) {
      const int a = result.order[i], b = result.order[i + 1];
      if (value(a) == value(b)) {
        throw Error("two series are at the same phase (" + ValueText(value(a), key) + "): " + phases[a].Describe() +
                        " and " + phases[b].Describe() + ", so the folder mixes series that are not one 4D CT",
                    where, "select the phases by series UID in cycle order, or keep one 4D CT per folder");
      }
    }
  }
  std::vector<double> sorted;
  for (int i : result.order) sorted.push_back(value(i));
  if (require_whole_cycle) CheckWhole(phases, key, sorted, where);
  for (int i : result.order) result.cycle_fraction.push_back(CycleFraction(phases[i], key));
  return result;
}

}  // namespace dg::io
