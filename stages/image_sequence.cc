#include "stages/image_sequence.h"

#include <fnmatch.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <regex>

#include "sim/error.h"

namespace dg::stages {
namespace {

namespace fs = std::filesystem;

// A printf integer field, as in "%d" or "%04d".
const std::regex kPrintfField(R"(%(0?)(\d*)d)");

std::string RegexEscape(const std::string& text) {
  static const std::regex kSpecial(R"([.^$|()\[\]{}*+?\\])");
  return std::regex_replace(text, kSpecial, R"(\$&)");
}

std::vector<std::string> NumberedFiles(const fs::path& directory, const std::string& name_pattern,
                                       const std::smatch& field, const std::string& pattern) {
  // No file system names files with more digits than a long holds.
  constexpr size_t kWidestField = 18;
  if (field[2].length() > 2 || (field[2].length() && std::stoul(field[2].str()) > kWidestField)) {
    throw Error("the number field " + field.str() + " is wider than " + std::to_string(kWidestField) + " digits",
                pattern, "give the width the files use, e.g. left_%04d.png for left_0000.png");
  }
  const std::string digits = field[2].length() ? "(\\d{" + field[2].str() + "})" : "(\\d+)";
  const std::regex name_regex(RegexEscape(field.prefix()) + digits + RegexEscape(field.suffix()));
  std::map<long, std::string> by_number;
  for (const fs::directory_entry& entry : fs::directory_iterator(directory)) {
    const std::string name = entry.path().filename().string();
    std::smatch match;
    if (std::regex_match(name, match, name_regex)) by_number[std::stol(match[1])] = entry.path().string();
  }
  std::vector<std::string> files;
  long expected = by_number.empty() ? 0 : by_number.begin()->first;
  for (const auto& [number, path] : by_number) {
    if (number != expected) {
      char missing[512];
      std::snprintf(missing, sizeof missing, name_pattern.c_str(), expected);
      throw Error("image sequence has a gap: " + (directory / missing).string() + " is missing (" +
                      std::to_string(files.size()) + " frames before it)",
                  pattern, "renumber the files consecutively, or remove the ones after the gap");
    }
    files.push_back(path);
    ++expected;
  }
  return files;
}

std::vector<std::string> GlobbedFiles(const fs::path& directory, const std::string& name_pattern) {
  std::vector<std::string> files;
  for (const fs::directory_entry& entry : fs::directory_iterator(directory)) {
    if (fnmatch(name_pattern.c_str(), entry.path().filename().c_str(), 0) == 0 && entry.is_regular_file()) {
      files.push_back(entry.path().string());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

std::vector<std::string> ListImageSequence(const std::string& pattern) {
  const fs::path path(pattern);
  const fs::path directory = path.has_parent_path() ? path.parent_path() : fs::path(".");
  const std::string name_pattern = path.filename().string();
  if (!fs::is_directory(directory)) {
    throw Error("no such directory: " + directory.string(), pattern, "check the path of the image sequence");
  }
  std::smatch field;
  const bool numbered = std::regex_search(name_pattern, field, kPrintfField);
  const std::vector<std::string> files =
      numbered ? NumberedFiles(directory, name_pattern, field, pattern) : GlobbedFiles(directory, name_pattern);
  if (files.empty()) {
    throw Error("no file matches the image sequence pattern", pattern,
                "check the pattern: a printf field like left_%04d.png or a glob like 'left_*.png' "
                "(quoted, so that the shell does not expand it)");
  }
  return files;
}

}  // namespace dg::stages
