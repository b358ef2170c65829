#pragma once

#include <cstdint>
#include <fstream>
#include <string>

#include "io/h5_file.h"
#include "io/h5_table.h"
#include "stages/track/feature_tracker.h"

namespace dg::tools {

// The tracks of a run as flat columns, one row per tracked point per frame,
// written as the frames come: HDF5 (group /tracks, one appendable dataset per
// column, {rows} or {rows, 2|3}) and optionally CSV (one header line, the same
// columns flattened). Each frame's rows are flushed to disk before the next
// frame, and the file's root attribute `complete` stays 0 until Finish(), so
// a run that is interrupted leaves a readable file of the frames it finished,
// marked incomplete (with /tracks attribute `frames` saying how many).
// Not thread-safe.
class TrackTable {
 public:
  // Creates the files (replacing any of those names); csv_path may be empty.
  // @throws dg::Error naming a file that cannot be created.
  TrackTable(const std::string& h5_path, const std::string& csv_path);

  // Appends one frame's tracked points and flushes them.
  // @throws dg::Error naming the file when writing fails.
  void Add(std::int64_t frame, double t_s, const stages::TrackFrame& tracks);

  // Marks the HDF5 file complete (root attribute complete = 1).
  void Finish();

  std::size_t rows() const { return table_.rows(); }
  std::size_t frames() const { return frames_; }

 private:
  void AddCsv(std::int64_t frame, double t_s, const stages::TrackFrame& tracks);

  io::H5Writer h5_;
  io::H5Table table_;
  std::string csv_path_;
  std::ofstream csv_;
  std::size_t frames_ = 0;
};

}  // namespace dg::tools
