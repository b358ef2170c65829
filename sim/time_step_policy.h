#pragma once

#include <initializer_list>
#include <string>

#include "sim/error.h"

namespace dg::sim {

// What to do when the requested step exceeds the safety fraction of dt_cr.
// Problem and scene files name it (time_step_policy:) by ToString's names.
enum class TimeStepPolicy {
  kRefuse,     // throw dg::Error naming both limits and the largest stable step
  kSubstep,    // split each step into the fewest equal substeps that are safe
  kUnchecked,  // run as asked (for stability studies); blow-ups are still detected
};

inline std::string ToString(TimeStepPolicy policy) {
  switch (policy) {
    case TimeStepPolicy::kRefuse: return "refuse";
    case TimeStepPolicy::kSubstep: return "substep";
    case TimeStepPolicy::kUnchecked: return "unchecked";
  }
  return "?";
}

// The policy ToString names `name`, among `allowed`.
// @throws dg::Error for any other name, at `where` (e.g. a file, line and key).
inline TimeStepPolicy ParseTimeStepPolicy(
    const std::string& name, const std::string& where,
    std::initializer_list<TimeStepPolicy> allowed = {TimeStepPolicy::kRefuse, TimeStepPolicy::kSubstep,
                                                     TimeStepPolicy::kUnchecked}) {
  std::string names;
  for (TimeStepPolicy policy : allowed) {
    if (ToString(policy) == name) return policy;
    names += (names.empty() ? "" : ", ") + ToString(policy);
  }
  throw Error("unknown time step policy '" + name + "'", where,
              "use one of " + names + " (refuse: a dt_s above the mesh's stable step is an error; substep: split "
              "into stable substeps)");
}

}  // namespace dg::sim
