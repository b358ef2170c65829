#include "io/units.h"

#include "sim/error.h"

namespace dg::io {

double MetresPerUnit(const std::string& unit, const std::string& where) {
  if (unit == "m") return 1.0;
  if (unit == "cm") return 1e-2;
  if (unit == "mm") return 1e-3;
  if (unit == "um") return 1e-6;
  throw Error("unknown length unit '" + unit + "'", where, "use one of m, cm, mm, um");
}

}  // namespace dg::io
