#pragma once

#include <string>
#include <type_traits>

#include "sim/error.h"

namespace dg::sim {

// The scalar a simulation's kernels run in: float (as the paper's GPU solver,
// the default) or double. Scene and problem files name it (precision:) by
// ToString's names.
enum class Precision { kFloat, kDouble };

inline std::string ToString(Precision precision) {
  switch (precision) {
    case Precision::kFloat: return "float";
    case Precision::kDouble: return "double";
  }
  return "?";
}

// The precision ToString names `name`.
// @throws dg::Error for any other name, at `where` (e.g. a file, line and key).
inline Precision ParsePrecision(const std::string& name, const std::string& where = "precision") {
  for (Precision precision : {Precision::kFloat, Precision::kDouble}) {
    if (ToString(precision) == name) return precision;
  }
  throw Error("unknown precision '" + name + "'", where, "use float (the default, faster) or double");
}

// The precision of the scalar type T (float or double).
template <typename T>
constexpr Precision PrecisionOf() {
  static_assert(std::is_same_v<T, float> || std::is_same_v<T, double>, "float or double");
  return std::is_same_v<T, float> ? Precision::kFloat : Precision::kDouble;
}

}  // namespace dg::sim
