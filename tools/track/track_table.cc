#include "tools/track/track_table.h"

#include <fstream>

#include "io/h5_file.h"
#include "sim/error.h"

namespace dg::tools {
namespace {

void Append(const Eigen::Vector2d& v, std::vector<double>* column) { column->insert(column->end(), {v.x(), v.y()}); }

}  // namespace

void TrackTable::Add(std::int64_t frame, double t_s, const stages::TrackFrame& tracks) {
  ++frames_;
  for (const stages::TrackedPoint& p : tracks.points) {
    frame_.push_back(static_cast<std::int32_t>(frame));
    t_s_.push_back(t_s);
    id_.push_back(static_cast<std::int32_t>(p.id));
    kind_.push_back(p.kind == stages::FeatureKind::kMser ? 1 : 0);
    Append(p.uv_left_R_px, &uv_left_R_px_);
    Append(p.uv_right_R_px, &uv_right_R_px_);
    Append(p.uv_left_px, &uv_left_px_);
    Append(p.uv_right_px, &uv_right_px_);
    xyz_C_m_.insert(xyz_C_m_.end(), {p.xyz_C_m.x(), p.xyz_C_m.y(), p.xyz_C_m.z()});
    quality_.push_back(p.quality);
  }
}

void TrackTable::WriteH5(const std::string& path) const {
  io::H5Writer out(path);
  const std::size_t n = rows();
  out.Write("/tracks/frame", frame_.data(), {n});
  out.Write("/tracks/t_s", t_s_.data(), {n});
  out.Write("/tracks/id", id_.data(), {n});
  out.Write("/tracks/kind", kind_.data(), {n});
  out.WriteAttribute("/tracks/kind", "values", std::string("0 corner, 1 MSER"));
  out.Write("/tracks/uv_left_R_px", uv_left_R_px_.data(), {n, 2});
  out.Write("/tracks/uv_right_R_px", uv_right_R_px_.data(), {n, 2});
  out.Write("/tracks/uv_left_px", uv_left_px_.data(), {n, 2});
  out.Write("/tracks/uv_right_px", uv_right_px_.data(), {n, 2});
  out.Write("/tracks/xyz_C_m", xyz_C_m_.data(), {n, 3});
  out.Write("/tracks/quality", quality_.data(), {n});
  out.WriteAttribute("/tracks", "frames", frames_);
}

void TrackTable::WriteCsv(const std::string& path) const {
  std::ofstream out(path);
  if (!out) throw Error("cannot write the tracks", path, "check the directory exists and is writable");
  out << "frame,t_s,id,kind,u_left_R_px,v_left_R_px,u_right_R_px,v_right_R_px,u_left_px,v_left_px,"
         "u_right_px,v_right_px,x_C_m,y_C_m,z_C_m,quality\n";
  out.precision(10);
  for (std::size_t i = 0; i < rows(); ++i) {
    out << frame_[i] << ',' << t_s_[i] << ',' << id_[i] << ',' << (kind_[i] ? "mser" : "corner");
    for (const std::vector<double>* uv : {&uv_left_R_px_, &uv_right_R_px_, &uv_left_px_, &uv_right_px_})
      out << ',' << (*uv)[2 * i] << ',' << (*uv)[2 * i + 1];
    out << ',' << xyz_C_m_[3 * i] << ',' << xyz_C_m_[3 * i + 1] << ',' << xyz_C_m_[3 * i + 2] << ',' << quality_[i]
        << '\n';
  }
  if (!out) throw Error("writing the tracks failed", path, "check the disk has space");
}

}  // namespace dg::tools
