#pragma once

#include <cstdio>
#include <string>

namespace dg::tools {

// A JSON string literal of text, quotes included: the figures files that
// commands write stay valid JSON whatever names a user gives.
inline std::string JsonQuoted(const std::string& text) {
  std::string quoted = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      quoted += '\\';
      quoted += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char escape[8];
      std::snprintf(escape, sizeof escape, "\\u%04x", c);
      quoted += escape;
    } else {
      quoted += c;
    }
  }
  return quoted + "\"";
}

}  // namespace dg::tools
