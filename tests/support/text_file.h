#pragma once

// A text file's contents, and the captures of a regular expression in a text:
// how tests read back the XML and YAML files the tools write. Header-only.
#include <fstream>
#include <iterator>
#include <regex>
#include <string>
#include <vector>

namespace dg::testing {

// The whole file; empty when it cannot be read.
inline std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), {}};
}

// The first capture group of every match of `pattern` in `text`, in order.
inline std::vector<std::string> Matches(const std::string& text, const std::string& pattern) {
  std::vector<std::string> found;
  const std::regex expression(pattern);
  for (std::sregex_iterator it(text.begin(), text.end(), expression), end; it != end; ++it) {
    found.push_back((*it)[1]);
  }
  return found;
}

}  // namespace dg::testing
