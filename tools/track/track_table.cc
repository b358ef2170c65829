#include "tools/track/track_table.h"

#include "sim/error.h"
#include "stages/track/track_rows.h"

namespace dg::tools {

TrackTable::TrackTable(const std::string& h5_path, const std::string& csv_path)
    : h5_(h5_path), table_(h5_, "/tracks", stages::TrackRowColumns()), csv_path_(csv_path) {
  h5_.WriteAttribute("/", "complete", 0);
  h5_.WriteAttribute("/tracks", "frames", 0);
  h5_.Flush();
  if (csv_path_.empty()) return;
  csv_.open(csv_path_);
  if (!csv_) throw Error("cannot write the tracks", csv_path_, "check the directory exists and is writable");
  csv_ << "frame,t_s,id,kind,u_left_R_px,v_left_R_px,u_right_R_px,v_right_R_px,u_left_px,v_left_px,"
          "u_right_px,v_right_px,x_C_m,y_C_m,z_C_m,quality\n";
  csv_.precision(10);
}

void TrackTable::Add(std::int64_t frame, double t_s, const stages::TrackFrame& tracks) {
  stages::AppendTrackRows(table_, frame, t_s, tracks);
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
