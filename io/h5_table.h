#pragma once

#include <concepts>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <span>
#include <string>
#include <vector>

#include "io/h5_file.h"

namespace dg::io {

enum class H5Type { kInt64, kInt32, kUInt8, kDouble, kFloat };

// One column of an H5Table: a dataset of shape {rows} (width 1) or
// {rows, width} (e.g. 3 for a point's xyz).
struct H5Column {
  std::string name;  // the dataset's name inside the table's group, e.g. "start_ns"
  H5Type type;
  std::size_t width = 1;
  // For a coded column, what its values mean (e.g. "0 corner, 1 MSER"): the
  // dataset's text attribute `values`, so a reader of the file need not guess.
  std::string values{};
};

// The values of one column for a block of rows: rows * width values in row
// order, of exactly the column's type (no silent narrowing: an int for an
// int64 column is an error). A single value converts implicitly, so a row of
// scalars reads `table.AppendRow({frame, stage, start_ns})`. Holds a pointer
// only: the values must outlive the Append call.
template <typename T>
concept H5Value = std::same_as<T, std::int64_t> || std::same_as<T, std::int32_t> ||
                  std::same_as<T, std::uint8_t> || std::same_as<T, double> || std::same_as<T, float>;

template <H5Value T>
constexpr H5Type H5TypeOf() {
  if constexpr (std::same_as<T, std::int64_t>) return H5Type::kInt64;
  if constexpr (std::same_as<T, std::int32_t>) return H5Type::kInt32;
  if constexpr (std::same_as<T, std::uint8_t>) return H5Type::kUInt8;
  if constexpr (std::same_as<T, double>) return H5Type::kDouble;
  if constexpr (std::same_as<T, float>) return H5Type::kFloat;
}

class H5Values {
 public:
  template <H5Value T>
  H5Values(std::span<const T> values) : type_(H5TypeOf<T>()), data_(values.data()), count_(values.size()) {}
  template <H5Value T>
  H5Values(const std::vector<T>& values) : H5Values(std::span<const T>(values)) {}
  template <H5Value T>
  H5Values(const T& value) : H5Values(std::span<const T>(&value, 1)) {}

  H5Type type() const { return type_; }
  const void* data() const { return data_; }
  std::size_t count() const { return count_; }

 private:
  H5Type type_;
  const void* data_;
  std::size_t count_;
};

// An appendable table in an HDF5 file: a group holding one dataset per
// column, each chunked along its rows, deflate-compressed and unlimited in
// length, so h5py reads a column as `f["/timings/start_ns"][:]` and h5dump
// shows it. Rows are buffered and written a chunk at a time; Flush() writes
// the rest and flushes the file, so a process that dies afterwards leaves a
// readable file with every row appended before the Flush (the columns of a
// row not yet flushed are lost together, except when the process dies inside
// Flush itself: then a reader takes the shortest column's length). Every
// write allocates its disk space first (h5::ReserveSpace) and flushes the
// file after, so a full disk fails the write before HDF5 touches the file:
// the rows written before stay readable, and the table writes no more.
//
// The table opens the H5Writer's file a second time (HDF5 shares one open
// file between the two identifiers), so the writer goes on writing other
// datasets and attributes beside the table. Not thread-safe: one thread
// appends (a pipeline's log sink). The destructor flushes; call Flush() to see
// its errors.
class H5Table {
 public:
  struct Options {
    std::size_t chunk_rows = 4096;  // rows per write, and per HDF5 chunk up to 256 KiB a chunk
    int deflate_level = 4;          // 0 (none) .. 9
    std::string Validate() const;   // empty when valid
  };

  // Creates the group (and missing parents) with empty columns.
  // @throws dg::Error naming the file and group when it exists, a column is
  // named twice or has width 0, or the options are invalid.
  H5Table(H5Writer& file, const std::string& group, std::vector<H5Column> columns, Options options);
  H5Table(H5Writer& file, const std::string& group, std::vector<H5Column> columns)
      : H5Table(file, group, std::move(columns), Options()) {}
  ~H5Table();
  H5Table(H5Table&& other) noexcept;
  H5Table& operator=(H5Table&&) = delete;
  H5Table(const H5Table&) = delete;
  H5Table& operator=(const H5Table&) = delete;

  // Appends `rows` rows: one H5Values per column, in the columns' order, each
  // of rows * width values. @throws dg::Error naming the column when a type or
  // count does not match (nothing is appended then).
  void Append(std::size_t rows, std::span<const H5Values> columns);
  void Append(std::size_t rows, std::initializer_list<H5Values> columns) {
    Append(rows, std::span<const H5Values>(columns.begin(), columns.size()));
  }
  void AppendRow(std::initializer_list<H5Values> columns) { Append(1, columns); }

  // Writes the buffered rows and flushes the whole file to disk.
  // @throws dg::Error naming the file and group when writing fails (then
  // and after: the table writes no more, and its destructor drops its rows).
  void Flush();
  // Flushes several tables of one file together: the space for all their
  // rows is reserved first, so that on a full disk every table stays at its
  // previous flush (none is a flush ahead of the others).
  // @throws dg::Error as Flush(); then none of the tables writes again.
  static void FlushTogether(std::span<H5Table* const> tables);
  // Drops the rows not yet written: the table writes no more, and its
  // destructor does not flush (for a log whose disk is full).
  void StopWriting();

  // Rows appended so far (written or buffered).
  std::size_t rows() const { return written_rows_ + buffered_rows_; }
  const std::vector<H5Column>& columns() const { return columns_; }

 private:
  void WriteColumns();  // the buffered rows, without a flush

  std::string path_;   // the file's
  std::string where_;  // file:group, for errors
  std::vector<H5Column> columns_;
  Options options_;
  std::int64_t file_ = -1;              // HDF5's hid_t of the second open of the file
  std::vector<std::int64_t> datasets_;  // one per column
  std::vector<std::vector<std::byte>> buffers_;
  std::size_t written_rows_ = 0, buffered_rows_ = 0;
  bool failed_ = false;
};

}  // namespace dg::io
