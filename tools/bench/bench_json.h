#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace dg::tools {

// printf into a string, for one record's JSON fields.
template <typename... Args>
std::string Printed(const char* format, Args... args) {
  const int size = std::snprintf(nullptr, 0, format, args...);
  std::string text(static_cast<size_t>(size), '\0');
  std::snprintf(text.data(), text.size() + 1, format, args...);
  return text;
}

// The saved figures of a benchmark: a JSON array, one object per line, each
// the record's own fields (`"key": value, ...`, one string per record)
// followed by the machine's (cpu, logical_cores, simd, compiler) and the
// run's provenance (commit, date, load_average_before at the process's start
// and load_average_after now, 1/5/15 minutes).
// @throws dg::Error when the file cannot be written.
void WriteBenchJson(const std::string& path, const std::vector<std::string>& record_fields);

}  // namespace dg::tools
