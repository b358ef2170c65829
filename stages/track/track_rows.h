#pragma once

#include <cstdint>
#include <vector>

#include "io/h5_table.h"
#include "stages/track/feature_tracker.h"

namespace dg::stages {

// The tracks as an appendable HDF5 table, one row per tracked point per frame
// (the /tracks of `dynaguide track`'s output and of a run log): frame, t_s,
// id, kind (0 corner, 1 MSER), uv_left_R_px, uv_right_R_px (rectified),
// uv_left_px, uv_right_px (original, distorted), xyz_C_m, quality.
std::vector<io::H5Column> TrackRowColumns();

// Appends one frame's points to a table made with TrackRowColumns().
void AppendTrackRows(io::H5Table& table, std::int64_t frame, double t_s, const TrackFrame& tracks);

}  // namespace dg::stages
