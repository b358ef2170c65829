#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace dg::tools {

// printf into a string, for the tables and texts a benchmark prints.
template <typename... Args>
std::string Printed(const char* format, Args... args) {
  const int size = std::snprintf(nullptr, 0, format, args...);
  std::string text(static_cast<size_t>(size), '\0');
  std::snprintf(text.data(), text.size() + 1, format, args...);
  return text;
}

// Prints the machine line a benchmark starts with: CPU, logical cores, SIMD,
// compiler.
void PrintMachine();

// Prints a benchmark's table and, when `json_path` is not empty, saves its
// records there with write(json_path, records) and says so.
template <typename Records, typename Write>
void PrintAndSave(const std::string& table, const std::string& json_path, const Records& records, Write write) {
  std::fputs(table.c_str(), stdout);
  if (json_path.empty()) return;
  write(json_path, records);
  std::printf("saved %s\n", json_path.c_str());
}

// The saved figures of a benchmark: a JSON array (nlohmann's writer, two
// spaces of indent), one object per record, each the record's own fields
// (records: one JSON object's text each, JsonText(record, -1) of
// tools/json_text.h, its keys in order) followed by the
// machine's (cpu, logical_cores, simd, compiler) and the run's provenance
// (commit, date, load_average_before at the process's start and
// load_average_after now, 1/5/15 minutes), then the host's peaks measured
// now (MeasureMachinePeaks, about a second: host_fma_fp32_gflops and
// host_triad_gb_s on 1, 2 threads, host_core_load_store_gb_s on each logical
// core alone). A figure that is not a finite number is
// written as null (docs/benchmarks.md).
// @throws dg::Error when the file cannot be written.
void WriteBenchJson(const std::string& path, const std::vector<std::string>& records);

}  // namespace dg::tools
