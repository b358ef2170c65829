#pragma once

#include <string>

namespace dg::io {

// Metres per unit for a length unit named in a file or option: "m", "cm", "mm",
// "um". Mesh files carry no units; scenes and problems say which they use.
// @throws dg::Error naming the unit and the accepted names.
double MetresPerUnit(const std::string& unit, const std::string& where);

}  // namespace dg::io
