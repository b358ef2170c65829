#include "stages/track/track_rows.h"

namespace dg::stages {
namespace {

void Append(const Eigen::Vector2d& v, std::vector<double>* column) { column->insert(column->end(), {v.x(), v.y()}); }

}  // namespace

std::vector<io::H5Column> TrackRowColumns() {
  using io::H5Type;
  return {{"frame", H5Type::kInt32},       {"t_s", H5Type::kDouble},
          {"id", H5Type::kInt32},          {"kind", H5Type::kUInt8, 1, "0 corner, 1 MSER"},
          {"uv_left_R_px", H5Type::kDouble, 2}, {"uv_right_R_px", H5Type::kDouble, 2},
          {"uv_left_px", H5Type::kDouble, 2},   {"uv_right_px", H5Type::kDouble, 2},
          {"xyz_C_m", H5Type::kDouble, 3}, {"quality", H5Type::kDouble}};
}

void AppendTrackRows(io::H5Table& table, std::int64_t frame, double t_s, const TrackFrame& tracks) {
  const std::size_t n = tracks.points.size();
  const std::vector<std::int32_t> frame_column(n, static_cast<std::int32_t>(frame));
  const std::vector<double> t_column(n, t_s);
  std::vector<std::int32_t> id;
  std::vector<std::uint8_t> kind;
  std::vector<double> uv_left_R, uv_right_R, uv_left, uv_right, xyz, quality;
  for (const TrackedPoint& p : tracks.points) {
    id.push_back(static_cast<std::int32_t>(p.id));
    kind.push_back(p.kind == FeatureKind::kMser ? 1 : 0);
    Append(p.uv_left_R_px, &uv_left_R);
    Append(p.uv_right_R_px, &uv_right_R);
    Append(p.uv_left_px, &uv_left);
    Append(p.uv_right_px, &uv_right);
    xyz.insert(xyz.end(), {p.xyz_C_m.x(), p.xyz_C_m.y(), p.xyz_C_m.z()});
    quality.push_back(p.quality);
  }
  table.Append(n, {frame_column, t_column, id, kind, uv_left_R, uv_right_R, uv_left, uv_right, xyz, quality});
}

}  // namespace dg::stages
