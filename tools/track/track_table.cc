#include "tools/track/track_table.h"

#include <vector>

#include "sim/error.h"

namespace dg::tools {
namespace {

std::vector<io::H5Column> TrackColumns() {
  using io::H5Type;
  return {{"frame", H5Type::kInt32},       {"t_s", H5Type::kDouble},
          {"id", H5Type::kInt32},          {"kind", H5Type::kUInt8},
          {"uv_left_R_px", H5Type::kDouble, 2}, {"uv_right_R_px", H5Type::kDouble, 2},
          {"uv_left_px", H5Type::kDouble, 2},   {"uv_right_px", H5Type::kDouble, 2},
          {"xyz_C_m", H5Type::kDouble, 3}, {"quality", H5Type::kDouble}};
}

void Append(const Eigen::Vector2d& v, std::vector<double>* column) { column->insert(column->end(), {v.x(), v.y()}); }

}  // namespace

TrackTable::TrackTable(const std::string& h5_path, const std::string& csv_path)
    : h5_(h5_path), table_(h5_, "/tracks", TrackColumns()), csv_path_(csv_path) {
  h5_.WriteAttribute("/", "complete", 0);
  h5_.WriteAttribute("/tracks", "frames", 0);
  h5_.WriteAttribute("/tracks/kind", "values", std::string("0 corner, 1 MSER"));
  h5_.Flush();
  if (csv_path_.empty()) return;
  csv_.open(csv_path_);
  if (!csv_) throw Error("cannot write the tracks", csv_path_, "check the directory exists and is writable");
  csv_ << "frame,t_s,id,kind,u_left_R_px,v_left_R_px,u_right_R_px,v_right_R_px,u_left_px,v_left_px,"
          "u_right_px,v_right_px,x_C_m,y_C_m,z_C_m,quality\n";
  csv_.precision(10);
}

void TrackTable::Add(std::int64_t frame, double t_s, const stages::TrackFrame& tracks) {
  const std::size_t n = tracks.points.size();
  const std::vector<std::int32_t> frame_column(n, static_cast<std::int32_t>(frame));
  const std::vector<double> t_column(n, t_s);
  std::vector<std::int32_t> id;
  std::vector<std::uint8_t> kind;
  std::vector<double> uv_left_R, uv_right_R, uv_left, uv_right, xyz, quality;
  for (const stages::TrackedPoint& p : tracks.points) {
    id.push_back(static_cast<std::int32_t>(p.id));
    kind.push_back(p.kind == stages::FeatureKind::kMser ? 1 : 0);
    Append(p.uv_left_R_px, &uv_left_R);
    Append(p.uv_right_R_px, &uv_right_R);
    Append(p.uv_left_px, &uv_left);
    Append(p.uv_right_px, &uv_right);
    xyz.insert(xyz.end(), {p.xyz_C_m.x(), p.xyz_C_m.y(), p.xyz_C_m.z()});
    quality.push_back(p.quality);
  }
  table_.Append(n, {frame_column, t_column, id, kind, uv_left_R, uv_right_R, uv_left, uv_right, xyz, quality});
  h5_.WriteAttribute("/tracks", "frames", ++frames_);
  table_.Flush();  // the rows and the attribute: the whole file
  if (csv_.is_open()) AddCsv(frame, t_s, tracks);
}

void TrackTable::AddCsv(std::int64_t frame, double t_s, const stages::TrackFrame& tracks) {
  for (const stages::TrackedPoint& p : tracks.points) {
    csv_ << frame << ',' << t_s << ',' << p.id << ',' << (p.kind == stages::FeatureKind::kMser ? "mser" : "corner");
    for (const Eigen::Vector2d* uv : {&p.uv_left_R_px, &p.uv_right_R_px, &p.uv_left_px, &p.uv_right_px})
      csv_ << ',' << uv->x() << ',' << uv->y();
    csv_ << ',' << p.xyz_C_m.x() << ',' << p.xyz_C_m.y() << ',' << p.xyz_C_m.z() << ',' << p.quality << '\n';
  }
  csv_.flush();
  if (!csv_) throw Error("writing the tracks failed", csv_path_, "check the disk has space");
}

void TrackTable::Finish() {
  table_.Flush();
  h5_.WriteAttribute("/", "complete", 1);
  h5_.Flush();
}

}  // namespace dg::tools
