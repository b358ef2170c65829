#include "io/h5_table.h"

#include <algorithm>
#include <cstring>
#include <exception>
#include <set>
#include <utility>

#include "io/h5_handle.h"
#include "sim/error.h"
#include "sim/log.h"

namespace dg::io {
namespace {

using h5::Checked;
using h5::Handle;
using h5::kMetadataBytes;
using h5::Quiet;
using h5::ReserveSpace;

// What HDF5 may add per column and per chunk beside the values: an object
// header or a chunk's B-tree entry.
constexpr hsize_t kColumnMetadataBytes = 4096;

hid_t NativeType(H5Type type) {
  switch (type) {
    case H5Type::kInt64: return H5T_NATIVE_INT64;
    case H5Type::kInt32: return H5T_NATIVE_INT32;
    case H5Type::kUInt8: return H5T_NATIVE_UINT8;
    case H5Type::kDouble: return H5T_NATIVE_DOUBLE;
    case H5Type::kFloat: return H5T_NATIVE_FLOAT;
  }
  DG_CHECK(false);
  return -1;
}

std::size_t SizeOf(H5Type type) {
  switch (type) {
    case H5Type::kInt64:
    case H5Type::kDouble: return 8;
    case H5Type::kInt32:
    case H5Type::kFloat: return 4;
    case H5Type::kUInt8: return 1;
  }
  DG_CHECK(false);
  return 0;
}

const char* TypeName(H5Type type) {
  switch (type) {
    case H5Type::kInt64: return "int64";
    case H5Type::kInt32: return "int32";
    case H5Type::kUInt8: return "uint8";
    case H5Type::kDouble: return "double";
    case H5Type::kFloat: return "float";
  }
  DG_CHECK(false);
  return "";
}

// The dimensions of `rows` rows of a column: {rows} or {rows, width}.
std::vector<hsize_t> Dims(const H5Column& column, std::size_t rows) {
  if (column.width == 1) return {rows};
  return {rows, column.width};
}

// A chunk of at most 256 KiB: HDF5 caches 1 MiB of chunks per dataset, and a
// write into a chunk not in the cache reads, inflates and deflates it whole
// (a 4096-row chunk of 256 sampled nodes would be 25 MB, rewritten at every
// flush). Narrow columns keep the table's chunk_rows.
constexpr hsize_t kMaxChunkBytes = 256 * 1024;

std::size_t ChunkRows(const H5Column& column, const H5Table::Options& options) {
  const hsize_t row_bytes = column.width * SizeOf(column.type);
  return static_cast<std::size_t>(std::clamp<hsize_t>(kMaxChunkBytes / row_bytes, 1, options.chunk_rows));
}

// An empty column dataset, unlimited along its rows, chunked and compressed.
hid_t CreateColumn(hid_t group, const H5Column& column, const H5Table::Options& options,
                   const std::string& where) {
  const std::vector<hsize_t> dims = Dims(column, 0);
  std::vector<hsize_t> max_dims = dims;
  max_dims[0] = H5S_UNLIMITED;
  std::vector<hsize_t> chunk = Dims(column, ChunkRows(column, options));
  Handle space(Checked(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), max_dims.data()),
                       "create a dataspace", where),
               H5Sclose);
  Handle properties(Checked(H5Pcreate(H5P_DATASET_CREATE), "create properties", where), H5Pclose);
  Checked(H5Pset_chunk(properties.get(), static_cast<int>(chunk.size()), chunk.data()), "set the chunk size",
          where);
  if (options.deflate_level > 0) {
    Checked(H5Pset_shuffle(properties.get()), "set the shuffle filter", where);
    Checked(H5Pset_deflate(properties.get(), static_cast<unsigned>(options.deflate_level)),
            "set deflate compression", where);
  }
  // Without modification times, the same rows give the same bytes (as H5Writer's datasets).
  Checked(H5Pset_obj_track_times(properties.get(), 0), "set properties", where);
  return Checked(H5Dcreate2(group, column.name.c_str(), NativeType(column.type), space.get(), H5P_DEFAULT,
                            properties.get(), H5P_DEFAULT),
                 "create column '" + column.name + "'", where);
}

// The disk space that writing `rows` rows after `written` may take: every
// chunk they touch is rewritten whole at a new place in the file, with its
// index entry. Uncompressed, a chunk takes its full size. Deflated, its
// values take at most 1% more than raw (zlib's bound is 0.03% and a few
// bytes a block), and the zeros that fill its unwritten rows at most 1% of
// the chunk (a deflate match codes 258 bytes in under 16 bits); when that
// would exceed the full size, HDF5 stores the chunk uncompressed.
hsize_t BytesToWrite(const std::vector<H5Column>& columns, const H5Table::Options& options, std::size_t written,
                     std::size_t rows) {
  const std::size_t end = written + rows;
  hsize_t bytes = kMetadataBytes;
  for (const H5Column& column : columns) {
    const std::size_t chunk_rows = ChunkRows(column, options);
    const hsize_t row_bytes = column.width * SizeOf(column.type);
    const hsize_t full = chunk_rows * row_bytes;
    for (std::size_t first = written / chunk_rows * chunk_rows; first < end; first += chunk_rows) {
      const hsize_t present = std::min(end, first + chunk_rows) - first;
      const hsize_t deflated = present * row_bytes * 101 / 100 + full / 100 + 1024;
      bytes += (options.deflate_level > 0 ? std::min(full, deflated) : full) + kColumnMetadataBytes;
    }
  }
  return bytes;
}

}  // namespace

std::string H5Table::Options::Validate() const {
  if (chunk_rows == 0) return "chunk_rows must be at least 1";
  if (deflate_level < 0 || deflate_level > 9) return "deflate_level must be 0..9";
  return "";
}

H5Table::H5Table(H5Writer& file, const std::string& group, std::vector<H5Column> columns, Options options)
    : path_(file.path()), where_(file.path() + ":" + group), columns_(std::move(columns)), options_(options) {
  if (const std::string problem = options_.Validate(); !problem.empty()) {
    throw Error("invalid table options: " + problem, where_, "pass valid H5Table::Options");
  }
  if (columns_.empty()) throw Error("a table needs at least one column", where_, "name its columns");
  std::set<std::string> names;
  for (const H5Column& column : columns_) {
    if (column.name.empty() || column.name.find('/') != std::string::npos || !names.insert(column.name).second ||
        column.width == 0) {
      throw Error("column '" + column.name + "' is empty, contains '/', is named twice or has width 0", where_,
                  "give each column a distinct plain name and a width of at least 1");
    }
  }
  // Everything written so far through the writer must be on disk before the
  // second identifier opens the file, so both see one consistent file.
  file.Flush();
  file_ = Checked(H5Fopen(file.path().c_str(), H5F_ACC_RDWR, H5P_DEFAULT), "reopen the file", where_);
  try {
    ReserveSpace(file_, kMetadataBytes + columns_.size() * kColumnMetadataBytes, where_);
    Handle link_properties(Checked(H5Pcreate(H5P_LINK_CREATE), "create properties", where_), H5Pclose);
    Checked(H5Pset_create_intermediate_group(link_properties.get(), 1), "set properties", where_);
    bool exists = false;
    H5E_BEGIN_TRY { exists = H5Lexists(file_, group.c_str(), H5P_DEFAULT) > 0; }  // fails for a missing parent
    H5E_END_TRY;
    if (exists) {
      throw Error("the table's group already exists", where_, "append to a new group or write a new file");
    }
    Handle group_id(Checked(H5Gcreate2(file_, group.c_str(), link_properties.get(), H5P_DEFAULT, H5P_DEFAULT),
                            "create the group", where_, "use an absolute path like /timings in a writable file"),
                    H5Gclose);
    for (const H5Column& column : columns_) {
      datasets_.push_back(CreateColumn(group_id.get(), column, options_, where_));
      buffers_.emplace_back();
      buffers_.back().reserve(options_.chunk_rows * column.width * SizeOf(column.type));
    }
  } catch (...) {
    for (hid_t dataset : datasets_) H5Dclose(dataset);
    H5Fclose(file_);
    throw;
  }
  for (const H5Column& column : columns_) {
    if (!column.values.empty()) file.WriteAttribute(group + "/" + column.name, "values", column.values);
  }
}

H5Table::H5Table(H5Table&& other) noexcept
    : path_(std::move(other.path_)),
      where_(std::move(other.where_)),
      columns_(std::move(other.columns_)),
      options_(other.options_),
      file_(std::exchange(other.file_, -1)),
      datasets_(std::move(other.datasets_)),
      buffers_(std::move(other.buffers_)),
      written_rows_(other.written_rows_),
      buffered_rows_(std::exchange(other.buffered_rows_, 0)),
      failed_(other.failed_) {
  other.datasets_.clear();
}

H5Table::~H5Table() {
  if (file_ < 0) return;
  Quiet();
  // A table whose write failed does not try again: its error was thrown then.
  if (!failed_) {
    try {
      Flush();
    } catch (const std::exception& error) {
      Logger("io").error("table rows lost on close: {}", error.what());
    }
  }
  for (hid_t dataset : datasets_) H5Dclose(dataset);
  if (const std::string problem = h5::CloseFile(file_, path_); !problem.empty()) Logger("io").error("{}", problem);
}

void H5Table::Append(std::size_t rows, std::span<const H5Values> columns) {
  if (columns.size() != columns_.size()) {
    throw Error("appended " + std::to_string(columns.size()) + " columns to a table of " +
                    std::to_string(columns_.size()),
                where_, "pass one block of values per column, in the columns' order");
  }
  for (std::size_t c = 0; c < columns.size(); ++c) {
    const H5Column& column = columns_[c];
    if (columns[c].type() != column.type || columns[c].count() != rows * column.width) {
      throw Error("column '" + column.name + "' takes " + std::to_string(rows * column.width) + " " +
                      TypeName(column.type) + " values for " + std::to_string(rows) + " rows, got " +
                      std::to_string(columns[c].count()) + " " + TypeName(columns[c].type()),
                  where_, "convert the values to the column's type and pass width values per row");
    }
  }
  for (std::size_t c = 0; c < columns.size(); ++c) {
    const auto* bytes = static_cast<const std::byte*>(columns[c].data());
    buffers_[c].insert(buffers_[c].end(), bytes, bytes + columns[c].count() * SizeOf(columns_[c].type));
  }
  buffered_rows_ += rows;
  if (buffered_rows_ >= options_.chunk_rows) Flush();
}

void H5Table::WriteColumns() {
  if (buffered_rows_ == 0) return;
  for (std::size_t c = 0; c < columns_.size(); ++c) {
    const H5Column& column = columns_[c];
    const std::vector<hsize_t> total = Dims(column, written_rows_ + buffered_rows_);
    Checked(H5Dset_extent(datasets_[c], total.data()), "extend column '" + column.name + "'", where_);
    Handle file_space(Checked(H5Dget_space(datasets_[c]), "get the dataspace", where_), H5Sclose);
    std::vector<hsize_t> start(total.size(), 0);
    start[0] = written_rows_;
    const std::vector<hsize_t> count = Dims(column, buffered_rows_);
    Checked(H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr),
            "select the new rows", where_);
    Handle memory_space(
        Checked(H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr), "create a dataspace", where_),
        H5Sclose);
    Checked(H5Dwrite(datasets_[c], NativeType(column.type), memory_space.get(), file_space.get(), H5P_DEFAULT,
                     buffers_[c].data()),
            "write column '" + column.name + "'", where_);
    buffers_[c].clear();
  }
  written_rows_ += buffered_rows_;
  buffered_rows_ = 0;
}

void H5Table::StopWriting() {
  failed_ = true;
  for (std::vector<std::byte>& buffer : buffers_) buffer.clear();
  buffered_rows_ = 0;
}

void H5Table::Flush() {
  H5Table* self = this;
  FlushTogether({&self, 1});
}

void H5Table::FlushTogether(std::span<H5Table* const> tables) {
  DG_CHECK(!tables.empty());
  const H5Table& first = *tables.front();
  const std::string& where = tables.size() == 1 ? first.where_ : first.path_;
  Quiet();
  hsize_t bytes = 0;
  for (const H5Table* table : tables) {
    DG_CHECK(table->path_ == first.path_);
    if (table->failed_) {
      throw Error("the table stopped writing after an earlier write failed", table->where_,
                  "see the first error; the rows flushed before it are in the file");
    }
    if (table->buffered_rows_ > 0) {
      bytes += BytesToWrite(table->columns_, table->options_, table->written_rows_, table->buffered_rows_);
    }
  }
  try {
    ReserveSpace(first.file_, bytes, where);
    for (H5Table* table : tables) table->WriteColumns();
    // Once, after all the tables: HDF5 places the chunks now, inside the space
    // just reserved (a flush may trim the file to its allocated end).
    Checked(H5Fflush(first.file_, H5F_SCOPE_GLOBAL), "flush the file", where);
  } catch (...) {
    for (H5Table* table : tables) table->failed_ = true;
    throw;
  }
}

}  // namespace dg::io
