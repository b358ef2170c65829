#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "stages/track/feature_tracker.h"

namespace dg::tools {

// The tracks of a run as flat columns, one row per tracked point per frame,
// so that frames append as rows and a reader filters by the frame column.
// Written as HDF5 (group /tracks, one dataset per column, {rows} or
// {rows, 2|3}) and as CSV (one header line, the same columns flattened).
class TrackTable {
 public:
  void Add(std::int64_t frame, double t_s, const stages::TrackFrame& tracks);

  std::size_t rows() const { return frame_.size(); }
  std::size_t frames() const { return frames_; }

  // @throws dg::Error naming the file when it cannot be written.
  void WriteH5(const std::string& path) const;
  void WriteCsv(const std::string& path) const;

 private:
  std::size_t frames_ = 0;
  std::vector<std::int32_t> frame_, id_;
  std::vector<std::uint8_t> kind_;  // 0 corner, 1 MSER
  std::vector<double> t_s_, quality_;
  std::vector<double> uv_left_R_px_, uv_right_R_px_, uv_left_px_, uv_right_px_;  // 2 per row
  std::vector<double> xyz_C_m_;                                                  // 3 per row
};

}  // namespace dg::tools
