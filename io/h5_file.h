#pragma once

#include <concepts>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace dg::io {

// A dataset's dimensions, slowest first (HDF5's and NumPy's row-major order):
// {} is a scalar, {n} a vector, {rows, cols} a matrix.
using H5Shape = std::vector<std::size_t>;

// Writes an HDF5 file of numeric datasets, strings and attributes, as truth.h5,
// scan.h5 and the run log use it. Paths are absolute ("/sim/energy_J");
// intermediate groups are created on the way. Data is row-major: the last
// dimension varies fastest, so a column-major Eigen::Matrix3Xd of N points is
// the shape {N, 3}. Not thread-safe; the file is closed by the destructor.
//
// Each write first allocates the disk space it may need, so a full disk or a
// file size limit fails that write with a dg::Error (the operating system's
// reason, "free space ..." as the fix) before HDF5 touches the file: the file
// keeps everything written before and still opens. HDF5's own error printing
// is silenced; its innermost cause is in the dg::Error instead.
class H5Writer {
 public:
  // Creates the file, replacing any file of that name.
  // @throws dg::Error when the file cannot be created.
  explicit H5Writer(const std::string& path);
  ~H5Writer();
  H5Writer(H5Writer&& other) noexcept;
  H5Writer& operator=(H5Writer&& other) noexcept;
  H5Writer(const H5Writer&) = delete;
  H5Writer& operator=(const H5Writer&) = delete;

  // Writes product(shape) values (one value for shape {}) as a new dataset.
  // @throws dg::Error naming the file and dataset when it exists or cannot be written.
  void Write(const std::string& dataset, const double* data, const H5Shape& shape);
  void Write(const std::string& dataset, const float* data, const H5Shape& shape);
  void Write(const std::string& dataset, const std::int32_t* data, const H5Shape& shape);
  void Write(const std::string& dataset, const std::uint8_t* data, const H5Shape& shape);

  // A scalar dataset, e.g. /period_s.
  void WriteScalar(const std::string& dataset, double value) { Write(dataset, &value, {}); }

  // A matrix as it prints: shape {rows, cols}, element (r, c) at r * cols + c.
  void WriteMatrix(const std::string& dataset, const Eigen::MatrixXd& matrix);

  // A UTF-8 text (any length, e.g. the scene file verbatim) as a scalar string.
  void WriteString(const std::string& dataset, const std::string& text);

  // Creates a group and any missing parents; an existing group is kept.
  void CreateGroup(const std::string& group);

  // Sets an attribute of an existing group or dataset ("/" is the root),
  // replacing one of the same name. Integers are stored as 64-bit.
  // @throws dg::Error naming the file and object when the object does not exist.
  void WriteAttribute(const std::string& object, const std::string& name, double value);
  void WriteAttribute(const std::string& object, const std::string& name, std::int64_t value);
  void WriteAttribute(const std::string& object, const std::string& name, const std::string& text);
  template <std::integral Integer>
  void WriteAttribute(const std::string& object, const std::string& name, Integer value) {
    WriteAttribute(object, name, static_cast<std::int64_t>(value));
  }

  // Writes buffered data to disk, so a run that stops later leaves it readable.
  void Flush();

  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::int64_t file_ = -1;  // HDF5's hid_t, kept out of this header with hdf5.h
};

// Reads such a file (or any HDF5 file). Values are converted by HDF5 to the
// type asked for, so an int32 dataset reads as double. Not thread-safe.
class H5Reader {
 public:
  // @throws dg::Error when the file does not exist or is not HDF5.
  explicit H5Reader(const std::string& path);
  ~H5Reader();
  H5Reader(H5Reader&& other) noexcept;
  H5Reader& operator=(H5Reader&& other) noexcept;
  H5Reader(const H5Reader&) = delete;
  H5Reader& operator=(const H5Reader&) = delete;

  // Whether a group or dataset exists at the path (false for a missing parent).
  bool Has(const std::string& object) const;
  bool HasAttribute(const std::string& object, const std::string& name) const;

  // @throws dg::Error naming the file and dataset when it is missing or not numeric.
  H5Shape Shape(const std::string& dataset) const;
  // T is double, float, std::int32_t or std::uint8_t. `shape` may be null.
  template <typename T>
  std::vector<T> Read(const std::string& dataset, H5Shape* shape = nullptr) const;
  double ReadScalar(const std::string& dataset) const;
  // A 2-D dataset (or a vector, as one column) back into the matrix WriteMatrix wrote.
  Eigen::MatrixXd ReadMatrix(const std::string& dataset) const;
  // A scalar string, fixed-length or variable-length.
  std::string ReadString(const std::string& dataset) const;

  // T is double, std::int64_t or std::string.
  // @throws dg::Error naming the file, object and attribute when missing or of another kind.
  template <typename T>
  T ReadAttribute(const std::string& object, const std::string& name) const;

  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::int64_t file_ = -1;
};

}  // namespace dg::io
