#pragma once

// Reading HDF5 files through the library's plain C API, as h5py and h5dump
// do, not through the writer's own code (io/h5_file): what tests of written
// files read back with. Header-only, for test files (Catch2's REQUIRE).
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <hdf5.h>

namespace dg::testing::h5_plain {

// A dataset's length, an integer or a string attribute, through the plain C API.
inline hsize_t Rows(hid_t file, const char* dataset) {
  const hid_t set = H5Dopen2(file, dataset, H5P_DEFAULT);
  REQUIRE(set >= 0);
  const hid_t space = H5Dget_space(set);
  hsize_t dims[2] = {0, 0};
  H5Sget_simple_extent_dims(space, dims, nullptr);
  H5Sclose(space);
  H5Dclose(set);
  return dims[0];
}

inline long long IntAttribute(hid_t file, const char* object, const char* name) {
  long long value = -1;
  const hid_t attribute = H5Aopen_by_name(file, object, name, H5P_DEFAULT, H5P_DEFAULT);
  REQUIRE(attribute >= 0);
  REQUIRE(H5Aread(attribute, H5T_NATIVE_LLONG, &value) >= 0);
  H5Aclose(attribute);
  return value;
}

// A variable-length UTF-8 string, as h5py reads one.
template <typename Read>
std::string VariableString(Read&& read) {
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, H5T_VARIABLE);
  H5Tset_cset(type, H5T_CSET_UTF8);
  char* text = nullptr;
  REQUIRE(read(type, &text) >= 0);
  std::string value = text;
  H5free_memory(text);
  H5Tclose(type);
  return value;
}

inline std::string StringAttribute(hid_t file, const char* object, const char* name) {
  const hid_t attribute = H5Aopen_by_name(file, object, name, H5P_DEFAULT, H5P_DEFAULT);
  REQUIRE(attribute >= 0);
  std::string value = VariableString([&](hid_t type, char** text) { return H5Aread(attribute, type, text); });
  H5Aclose(attribute);
  return value;
}

inline std::string StringDataset(hid_t file, const char* name) {
  const hid_t set = H5Dopen2(file, name, H5P_DEFAULT);
  REQUIRE(set >= 0);
  std::string value = VariableString(
      [&](hid_t type, char** text) { return H5Dread(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, text); });
  H5Dclose(set);
  return value;
}

// Every value of a dataset, row-major (a 2-D dataset's rows one after another).
inline std::vector<double> Doubles(hid_t file, const char* dataset) {
  const hid_t set = H5Dopen2(file, dataset, H5P_DEFAULT);
  REQUIRE(set >= 0);
  const hid_t space = H5Dget_space(set);
  std::vector<double> values(static_cast<size_t>(H5Sget_simple_extent_npoints(space)));
  H5Sclose(space);
  REQUIRE(H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) >= 0);
  H5Dclose(set);
  return values;
}

}  // namespace dg::testing::h5_plain
