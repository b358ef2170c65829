#pragma once

// What pydicom reads in DICOM files (tests/io/ct/dicom_facts.py run by
// Debian's /usr/bin/python3): the independent truth of the DICOM tests.
// Header-only, for test files (Catch2's REQUIRE).
#include <cstdio>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

namespace dg::testing {

struct PydicomFile {
  std::string name;
  std::map<std::string, std::vector<std::string>> tags;  // keyword -> values
  std::vector<double> hu;                                // rows of pixels, rescale applied

  bool Has(const std::string& keyword) const { return tags.count(keyword) > 0; }
  const std::string& Text(const std::string& keyword, size_t i = 0) const {
    INFO(name << ": " << keyword);
    REQUIRE(Has(keyword));
    REQUIRE(tags.at(keyword).size() > i);
    return tags.at(keyword)[i];
  }
  double Number(const std::string& keyword, size_t i = 0) const { return std::stod(Text(keyword, i)); }
};

// Every DICOM file at `path` (a file, or a folder's files by name).
inline std::vector<PydicomFile> ReadWithPydicom(const std::string& path, bool pixels) {
  const std::string command = "/usr/bin/python3 " DG_SOURCE_DIR "/tests/io/ct/dicom_facts.py '" + path + "'" +
                              (pixels ? " --pixels" : "") + " 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  REQUIRE(pipe != nullptr);
  std::string output;
  char buffer[65536];
  for (size_t n; (n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) output.append(buffer, n);
  const int status = ::pclose(pipe);
  INFO("pydicom (Debian's python3-pydicom, installed by tools/setup.sh) failed: " << command << "\n" << output);
  REQUIRE(status == 0);
  std::vector<PydicomFile> files;
  std::istringstream lines(output);
  for (std::string line; std::getline(lines, line);) {
    std::istringstream words(line);
    std::string key;
    words >> key;
    if (key == "file") {
      files.emplace_back();
      words >> files.back().name;
      continue;
    }
    REQUIRE(!files.empty());
    if (key == "hu") {
      for (double v; words >> v;) files.back().hu.push_back(v);
      continue;
    }
    std::vector<std::string>& values = files.back().tags[key];
    for (std::string v; words >> v;) values.push_back(v);
  }
  return files;
}

}  // namespace dg::testing
