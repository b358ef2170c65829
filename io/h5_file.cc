#include "io/h5_file.h"

#include <cstring>
#include <filesystem>
#include <functional>
#include <numeric>
#include <type_traits>
#include <utility>

#include "io/h5_handle.h"
#include "sim/error.h"
#include "sim/log.h"

namespace dg::io {
namespace {

static_assert(std::is_same_v<hid_t, std::int64_t>, "the headers keep hid_t as std::int64_t");

using h5::Checked;
using h5::Handle;
using h5::kMetadataBytes;
using h5::Quiet;
using h5::ReserveSpace;
using h5::Untimed;

std::string Where(const std::string& path, const std::string& object) {
  return path + ":" + object;
}

std::string AttributeWhere(const std::string& path, const std::string& object,
                           const std::string& name) {
  return Where(path, object) + " attribute '" + name + "'";
}

template <typename T>
hid_t NativeType() {
  if constexpr (std::is_same_v<T, double>) return H5T_NATIVE_DOUBLE;
  if constexpr (std::is_same_v<T, float>) return H5T_NATIVE_FLOAT;
  if constexpr (std::is_same_v<T, std::int32_t>) return H5T_NATIVE_INT32;
  if constexpr (std::is_same_v<T, std::int64_t>) return H5T_NATIVE_INT64;
  if constexpr (std::is_same_v<T, std::uint8_t>) return H5T_NATIVE_UINT8;
}

// A variable-length UTF-8 string type, which holds any text without a length
// fixed in advance (h5py and h5dump read it).
Handle StringType(const std::string& where) {
  Handle type(Checked(H5Tcopy(H5T_C_S1), "copy the string type", where), H5Tclose);
  Checked(H5Tset_size(type.get(), H5T_VARIABLE), "size the string type", where);
  Checked(H5Tset_cset(type.get(), H5T_CSET_UTF8), "set the string character set", where);
  return type;
}

Handle Dataspace(const H5Shape& shape, const std::string& where) {
  if (shape.empty()) {
    return Handle(Checked(H5Screate(H5S_SCALAR), "create a dataspace", where), H5Sclose);
  }
  const std::vector<hsize_t> dims(shape.begin(), shape.end());
  return Handle(Checked(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr),
                        "create a dataspace", where),
                H5Sclose);
}

// Link creation properties that make the missing groups of a path on the way.
Handle CreatingParents(const std::string& where) {
  Handle properties(Checked(H5Pcreate(H5P_LINK_CREATE), "create properties", where), H5Pclose);
  Checked(H5Pset_create_intermediate_group(properties.get(), 1), "set properties", where);
  return properties;
}

// Every read and most writes pass here first, so it also silences HDF5's
// error printing on the calling thread (h5::Quiet).
bool Exists(hid_t file, const std::string& object) {
  Quiet();
  if (object == "/") return true;
  // H5Lexists fails, rather than answering false, when a parent is missing,
  // so the path is walked one link at a time.
  for (size_t end = object.find('/', 1);; end = object.find('/', end + 1)) {
    const std::string prefix = object.substr(0, end);
    if (H5Lexists(file, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
    if (end == std::string::npos) return true;
  }
}

void RequireAbsolute(const std::string& object, const std::string& where) {
  if (object.empty() || object.front() != '/') {
    throw Error("HDF5 path '" + object + "' is not absolute", where,
                "start the path at the root, e.g. /sim/energy_J");
  }
}

// A dataset or an attribute: the two are read and written alike except for
// HDF5's function names.
struct Data {
  hid_t id;
  bool attribute;

  hid_t Type() const { return attribute ? H5Aget_type(id) : H5Dget_type(id); }
  hid_t Space() const { return attribute ? H5Aget_space(id) : H5Dget_space(id); }
  herr_t Read(hid_t memory_type, void* buffer) const {
    return attribute ? H5Aread(id, memory_type, buffer)
                     : H5Dread(id, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer);
  }
  herr_t Write(hid_t memory_type, const void* buffer) const {
    return attribute ? H5Awrite(id, memory_type, buffer)
                     : H5Dwrite(id, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer);
  }
};

H5Shape ShapeOf(const Data& data, const std::string& where) {
  Handle space(Checked(data.Space(), "get the dataspace", where), H5Sclose);
  const int rank = Checked(H5Sget_simple_extent_ndims(space.get()), "get the rank", where);
  std::vector<hsize_t> dims(rank);
  Checked(H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr), "get the dimensions",
          where);
  return H5Shape(dims.begin(), dims.end());
}

size_t NumValues(const H5Shape& shape) {
  return std::accumulate(shape.begin(), shape.end(), size_t{1}, std::multiplies<>());
}

H5T_class_t ClassOf(const Data& data, const std::string& where) {
  Handle type(Checked(data.Type(), "get the type", where), H5Tclose);
  return H5Tget_class(type.get());
}

void RequireClass(const Data& data, std::initializer_list<H5T_class_t> accepted,
                  const std::string& kind, const std::string& where) {
  const H5T_class_t found = ClassOf(data, where);
  for (H5T_class_t c : accepted) {
    if (c == found) return;
  }
  throw Error("expected " + kind + " data", where,
              "read it with the function for its type (h5dump -H shows the type)");
}

std::string ReadText(const Data& data, const std::string& where) {
  RequireClass(data, {H5T_STRING}, "string", where);
  if (NumValues(ShapeOf(data, where)) != 1) {
    throw Error("expected a single string", where, "write the text as one scalar string");
  }
  Handle stored(Checked(data.Type(), "get the type", where), H5Tclose);
  if (H5Tis_variable_str(stored.get()) > 0) {
    const Handle type = StringType(where);
    char* text = nullptr;
    Checked(data.Read(type.get(), &text), "read the string", where);
    std::string result = text ? text : "";
    H5free_memory(text);
    return result;
  }
  // Fixed length: the stored size, padded with NULs or spaces after the text.
  const size_t size = H5Tget_size(stored.get());
  Handle type(Checked(H5Tcopy(H5T_C_S1), "copy the string type", where), H5Tclose);
  Checked(H5Tset_size(type.get(), size), "size the string type", where);
  std::vector<char> buffer(size);
  Checked(data.Read(type.get(), buffer.data()), "read the string", where);
  return std::string(buffer.data(), strnlen(buffer.data(), size));
}

void WriteText(const Data& data, const std::string& text, const std::string& where) {
  const Handle type = StringType(where);
  const char* pointer = text.c_str();
  Checked(data.Write(type.get(), &pointer), "write the string", where);
}

// A new dataset of `type` and `shape`, with its parent groups.
Handle CreateDataset(hid_t file, const std::string& dataset, hid_t type, const H5Shape& shape,
                     const std::string& where) {
  RequireAbsolute(dataset, where);
  if (Exists(file, dataset)) {
    throw Error("the dataset already exists", where,
                "write each dataset once, or choose another name");
  }
  const Handle space = Dataspace(shape, where);
  const Handle links = CreatingParents(where);
  const Handle creation = Untimed(H5P_DATASET_CREATE, where);
  return Handle(Checked(H5Dcreate2(file, dataset.c_str(), type, space.get(), links.get(),
                                   creation.get(), H5P_DEFAULT),
                        "create the dataset", where),
                H5Dclose);
}

// Numbers are stored in the type they have in memory.
void WriteNumbers(hid_t file, const std::string& path, const std::string& dataset, hid_t type,
                  const void* data, const H5Shape& shape) {
  const std::string where = Where(path, dataset);
  ReserveSpace(file, NumValues(shape) * H5Tget_size(type) + kMetadataBytes, where);
  const Handle set = CreateDataset(file, dataset, type, shape, where);
  Checked(Data{set.get(), false}.Write(type, data), "write the dataset", where);
}

}  // namespace

// ---------------------------------------------------------------- H5Writer

H5Writer::H5Writer(const std::string& path) : path_(path) {
  Quiet();
  // Checked here so that the common mistake gets a plain message, not HDF5's error stack.
  const std::filesystem::path directory = std::filesystem::path(path).parent_path();
  if (!directory.empty() && !std::filesystem::is_directory(directory)) {
    throw Error("the output directory does not exist", path,
                "create it first, or choose another path");
  }
  file_ = Checked(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT),
                  "create the file", path);
}

H5Writer::~H5Writer() {
  if (file_ < 0) return;
  if (const std::string problem = h5::CloseFile(file_, path_); !problem.empty()) {
    Logger("io").error("{}", problem);
  }
}

H5Writer::H5Writer(H5Writer&& other) noexcept
    : path_(std::move(other.path_)), file_(std::exchange(other.file_, -1)) {}

H5Writer& H5Writer::operator=(H5Writer&& other) noexcept {
  std::swap(path_, other.path_);
  std::swap(file_, other.file_);
  return *this;
}

void H5Writer::Write(const std::string& dataset, const double* data, const H5Shape& shape) {
  WriteNumbers(file_, path_, dataset, NativeType<double>(), data, shape);
}

void H5Writer::Write(const std::string& dataset, const float* data, const H5Shape& shape) {
  WriteNumbers(file_, path_, dataset, NativeType<float>(), data, shape);
}

void H5Writer::Write(const std::string& dataset, const std::int32_t* data, const H5Shape& shape) {
  WriteNumbers(file_, path_, dataset, NativeType<std::int32_t>(), data, shape);
}

void H5Writer::Write(const std::string& dataset, const std::uint8_t* data, const H5Shape& shape) {
  WriteNumbers(file_, path_, dataset, NativeType<std::uint8_t>(), data, shape);
}

void H5Writer::WriteMatrix(const std::string& dataset, const Eigen::MatrixXd& matrix) {
  const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> row_major = matrix;
  Write(dataset, row_major.data(),
        {static_cast<size_t>(matrix.rows()), static_cast<size_t>(matrix.cols())});
}

void H5Writer::WriteString(const std::string& dataset, const std::string& text) {
  Quiet();
  const std::string where = Where(path_, dataset);
  ReserveSpace(file_, text.size() + kMetadataBytes, where);
  const Handle type = StringType(where);
  const Handle set = CreateDataset(file_, dataset, type.get(), {}, where);
  WriteText(Data{set.get(), false}, text, where);
}

void H5Writer::CreateGroup(const std::string& group) {
  const std::string where = Where(path_, group);
  RequireAbsolute(group, where);
  if (Exists(file_, group)) return;
  ReserveSpace(file_, kMetadataBytes, where);
  const Handle links = CreatingParents(where);
  const Handle creation = Untimed(H5P_GROUP_CREATE, where);
  Handle created(Checked(H5Gcreate2(file_, group.c_str(), links.get(), creation.get(), H5P_DEFAULT),
                         "create the group", where),
                 H5Gclose);
}

namespace {

// Creates (or replaces) an attribute of `object`, of `bytes` bytes, and writes it through `write`.
void SetAttribute(hid_t file, const std::string& path, const std::string& object,
                  const std::string& name, hid_t type, size_t bytes,
                  const std::function<herr_t(const Data&)>& write) {
  const std::string where = AttributeWhere(path, object, name);
  if (!Exists(file, object)) {
    throw Error("the object of the attribute does not exist", where,
                "write the dataset or create the group first");
  }
  ReserveSpace(file, bytes + kMetadataBytes, where);
  Handle owner(Checked(H5Oopen(file, object.c_str(), H5P_DEFAULT), "open the object", where),
               H5Oclose);
  if (Checked(H5Aexists(owner.get(), name.c_str()), "look up the attribute", where) > 0) {
    Checked(H5Adelete(owner.get(), name.c_str()), "replace the attribute", where);
  }
  const Handle space = Dataspace({}, where);
  Handle attribute(
      Checked(H5Acreate2(owner.get(), name.c_str(), type, space.get(), H5P_DEFAULT, H5P_DEFAULT),
              "create the attribute", where),
      H5Aclose);
  Checked(write(Data{attribute.get(), true}), "write the attribute", where);
}

}  // namespace

void H5Writer::WriteAttribute(const std::string& object, const std::string& name, double value) {
  SetAttribute(file_, path_, object, name, H5T_NATIVE_DOUBLE, sizeof value,
               [&](const Data& data) { return data.Write(H5T_NATIVE_DOUBLE, &value); });
}

void H5Writer::WriteAttribute(const std::string& object, const std::string& name,
                              std::int64_t value) {
  SetAttribute(file_, path_, object, name, H5T_NATIVE_INT64, sizeof value,
               [&](const Data& data) { return data.Write(H5T_NATIVE_INT64, &value); });
}

void H5Writer::WriteAttribute(const std::string& object, const std::string& name,
                              const std::string& text) {
  Quiet();
  const std::string where = AttributeWhere(path_, object, name);
  const Handle type = StringType(where);
  SetAttribute(file_, path_, object, name, type.get(), text.size(), [&](const Data& data) {
    WriteText(data, text, where);
    return herr_t{0};
  });
}

void H5Writer::Flush() {
  Quiet();
  Checked(H5Fflush(file_, H5F_SCOPE_GLOBAL), "flush the file", path_);
}

// ---------------------------------------------------------------- H5Reader

namespace {

const std::string kReadFix = "check the file and the dataset's name (h5dump -n FILE lists them)";

Handle OpenDataset(hid_t file, const std::string& path, const std::string& dataset) {
  const std::string where = Where(path, dataset);
  if (!Exists(file, dataset)) throw Error("no such dataset", where, kReadFix);
  return Handle(Checked(H5Dopen2(file, dataset.c_str(), H5P_DEFAULT), "open the dataset", where,
                        "check that the path names a dataset, not a group"),
                H5Dclose);
}

}  // namespace

H5Reader::H5Reader(const std::string& path) : path_(path) {
  Quiet();
  if (!std::filesystem::is_regular_file(path)) {
    throw Error("no such HDF5 file", path, "check the path");
  }
  file_ = Checked(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), "open the file", path,
                  "check that it is an HDF5 file (h5dump -H shows its structure)");
}

H5Reader::~H5Reader() {
  Quiet();
  if (file_ >= 0) H5Fclose(file_);
}

H5Reader::H5Reader(H5Reader&& other) noexcept
    : path_(std::move(other.path_)), file_(std::exchange(other.file_, -1)) {}

H5Reader& H5Reader::operator=(H5Reader&& other) noexcept {
  std::swap(path_, other.path_);
  std::swap(file_, other.file_);
  return *this;
}

bool H5Reader::Has(const std::string& object) const {
  return !object.empty() && object.front() == '/' && Exists(file_, object);
}

bool H5Reader::HasAttribute(const std::string& object, const std::string& name) const {
  return Has(object) && H5Aexists_by_name(file_, object.c_str(), name.c_str(), H5P_DEFAULT) > 0;
}

H5Shape H5Reader::Shape(const std::string& dataset) const {
  const Handle set = OpenDataset(file_, path_, dataset);
  return ShapeOf(Data{set.get(), false}, Where(path_, dataset));
}

template <typename T>
std::vector<T> H5Reader::Read(const std::string& dataset, H5Shape* shape) const {
  const std::string where = Where(path_, dataset);
  const Handle set = OpenDataset(file_, path_, dataset);
  const Data data{set.get(), false};
  RequireClass(data, {H5T_INTEGER, H5T_FLOAT}, "numeric", where);
  const H5Shape dims = ShapeOf(data, where);
  std::vector<T> values(NumValues(dims));
  Checked(data.Read(NativeType<T>(), values.data()), "read the dataset", where, kReadFix);
  if (shape) *shape = dims;
  return values;
}

template std::vector<double> H5Reader::Read(const std::string&, H5Shape*) const;
template std::vector<float> H5Reader::Read(const std::string&, H5Shape*) const;
template std::vector<std::int64_t> H5Reader::Read(const std::string&, H5Shape*) const;
template std::vector<std::int32_t> H5Reader::Read(const std::string&, H5Shape*) const;
template std::vector<std::uint8_t> H5Reader::Read(const std::string&, H5Shape*) const;

double H5Reader::ReadScalar(const std::string& dataset) const {
  H5Shape shape;
  const std::vector<double> values = Read<double>(dataset, &shape);
  if (values.size() != 1) {
    throw Error("expected a single value, found " + std::to_string(values.size()),
                Where(path_, dataset), "read it as an array");
  }
  return values[0];
}

Eigen::MatrixXd H5Reader::ReadMatrix(const std::string& dataset) const {
  H5Shape shape;
  const std::vector<double> values = Read<double>(dataset, &shape);
  if (shape.size() > 2) {
    throw Error("expected at most 2 dimensions, found " + std::to_string(shape.size()),
                Where(path_, dataset), "read it with Read<double>() and its shape");
  }
  const Eigen::Index rows = shape.empty() ? 1 : static_cast<Eigen::Index>(shape[0]);
  const Eigen::Index cols = shape.size() == 2 ? static_cast<Eigen::Index>(shape[1]) : 1;
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      values.data(), rows, cols);
}

std::string H5Reader::ReadString(const std::string& dataset) const {
  const Handle set = OpenDataset(file_, path_, dataset);
  return ReadText(Data{set.get(), false}, Where(path_, dataset));
}

template <typename T>
T H5Reader::ReadAttribute(const std::string& object, const std::string& name) const {
  const std::string where = AttributeWhere(path_, object, name);
  if (!HasAttribute(object, name)) throw Error("no such attribute", where, kReadFix);
  Handle attribute(
      Checked(H5Aopen_by_name(file_, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT),
              "open the attribute", where, kReadFix),
      H5Aclose);
  const Data data{attribute.get(), true};
  if constexpr (std::is_same_v<T, std::string>) {
    return ReadText(data, where);
  } else {
    // An integer reads as a double; a floating-point value would be truncated as an integer.
    if constexpr (std::is_same_v<T, double>) {
      RequireClass(data, {H5T_INTEGER, H5T_FLOAT}, "numeric", where);
    } else {
      RequireClass(data, {H5T_INTEGER}, "integer", where);
    }
    if (NumValues(ShapeOf(data, where)) != 1) {
      throw Error("expected a single value", where, "read a scalar attribute");
    }
    T value{};
    Checked(data.Read(NativeType<T>(), &value), "read the attribute", where, kReadFix);
    return value;
  }
}

template double H5Reader::ReadAttribute(const std::string&, const std::string&) const;
template std::int64_t H5Reader::ReadAttribute(const std::string&, const std::string&) const;
template std::string H5Reader::ReadAttribute(const std::string&, const std::string&) const;

}  // namespace dg::io
