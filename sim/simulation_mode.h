#pragma once

#include <string>

#include "sim/error.h"

namespace dg::sim {

// What drives the image-constrained simulation:
//   kSurface  - positional constraints only (no inverse simulation at all);
//   kVolume   - forces recovered from the preoperative motion only;
//   kCombined - both (paper section 2.6).
// Scene files name it (simulation.mode, docs/formats/scene.md) by ToString's names.
enum class SimulationMode { kSurface, kVolume, kCombined };

inline std::string ToString(SimulationMode mode) {
  switch (mode) {
    case SimulationMode::kSurface: return "surface";
    case SimulationMode::kVolume: return "volume";
    case SimulationMode::kCombined: return "combined";
  }
  return "?";
}

// The mode ToString names `name`.
// @throws dg::Error for any other name, at `where` (e.g. a file, line and key).
inline SimulationMode ParseSimulationMode(const std::string& name, const std::string& where = "simulation mode") {
  for (SimulationMode mode : {SimulationMode::kSurface, SimulationMode::kVolume, SimulationMode::kCombined}) {
    if (ToString(mode) == name) return mode;
  }
  throw Error("unknown simulation mode '" + name + "'", where,
              "use surface, volume or combined (surface: the tracked surface only; volume: forces recovered from "
              "the scan's motion only; combined: both)");
}

}  // namespace dg::sim
