#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

// Helpers for the .cc files that write JSON with nlohmann's library
// (nlohmann::ordered_json: the keys in the order written). This header
// includes no JSON library: those files include <nlohmann/json.hpp> themselves.

namespace dg::tools {

// The text of a JSON file: json (a nlohmann::ordered_json) with `indent`
// spaces per level (-1: one line), then a newline. Text that is not UTF-8
// (a file name a user gave) has its bad bytes replaced by U+FFFD rather than
// failing the write; a NaN or infinite number is written as null.
template <typename Json>
std::string JsonText(const Json& json, int indent = 2) {
  return json.dump(indent, ' ', false, Json::error_handler_t::replace) + (indent < 0 ? "" : "\n");
}

// A figure cut to the digits it is stated with in the JSON files the commands
// write (a timing to 4 significant digits, a calibration error to 1e-6 px):
// the double nearest to printf's "%.*g" (Significant) or "%.*f" (Decimals)
// of value, which nlohmann's writer prints back as those digits. NaN and the
// infinities pass through.
inline double Significant(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*g", digits, value);
  return std::strtod(text, nullptr);
}

// Significant of each value, for a figure stated per thread or per core.
inline std::vector<double> SignificantEach(std::vector<double> values, int digits) {
  for (double& value : values) value = Significant(value, digits);
  return values;
}

inline double Decimals(double value, int digits) {
  char text[400];  // "%.*f" of the largest double: 309 integer digits
  std::snprintf(text, sizeof text, "%.*f", digits, value);
  return std::strtod(text, nullptr);
}

// 1, 5 and 15 minute load averages as a JSON array, to 0.01.
template <typename Json>
Json LoadAverageJson(const double (&average)[3]) {
  return Json::array({Decimals(average[0], 2), Decimals(average[1], 2), Decimals(average[2], 2)});
}

}  // namespace dg::tools
