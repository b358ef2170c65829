#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>

namespace dg::testing {

// A file or folder of the real data sets (the CMake cache variable
// DG_REAL_DATA_DIR), e.g. RealData("03_ct_abdomen_totalseg/ct_abdomen_3mm.nii.gz").
// Throws, failing the test, when it is missing: a test on real data never
// passes for want of it.
inline std::string RealData(const std::string& relative) {
  const std::filesystem::path path = std::filesystem::path(DG_REAL_DATA_DIR) / relative;
  if (!std::filesystem::exists(path)) {
    throw std::runtime_error("real data set missing: " + path.string() +
                             " (configure with -DDG_REAL_DATA_DIR=<folder of the real data sets>)");
  }
  return path.string();
}

}  // namespace dg::testing
