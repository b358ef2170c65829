#include "tools/phantom/phantom_generator.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "io/calibration.h"
#include "io/gmsh_mesher.h"
#include "io/h5_file.h"
#include "io/metaimage.h"
#include "io/xdmf_writer.h"
#include "io/surface_mesh.h"
#include "sim/error.h"
#include "stages/camera_model.h"
#include "tools/phantom/chessboard.h"
#include "tools/phantom/ct_export.h"
#include "tools/phantom/ct_synthesis.h"
#include "tools/phantom/distorted_view.h"
#include "tools/phantom/heart_geometry.h"
#include "tools/phantom/heart_motion.h"
#include "tools/phantom/scene_file.h"
#include "tools/phantom/stereo_rig.h"
#include "tools/phantom/surface_assets.h"
#include "tools/phantom/uncompressed_avi.h"

namespace dg::tools::phantom {
namespace {

namespace fs = std::filesystem;
namespace render = stages::render;

// Points hidden behind the surface are at least millimetres behind it; points
// on it are within the render's depth interpolation.
constexpr double kVisibilityTolerance_m = 3e-4;

void Step(bool progress, const char* what) {
  if (progress) std::fprintf(stderr, "phantom: %s\n", what);
}

// Area-weighted vertex normals of a triangle mesh (unnormalised is fine for the renderer).
Eigen::Matrix3Xd VertexNormals(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles) {
  Eigen::Matrix3Xd normals = Eigen::Matrix3Xd::Zero(3, vertices.cols());
  for (Eigen::Index t = 0; t < triangles.cols(); ++t) {
    const Eigen::Vector3d a = vertices.col(triangles(0, t)), b = vertices.col(triangles(1, t)), c = vertices.col(triangles(2, t));
    const Eigen::Vector3d n = (b - a).cross(c - a);
    for (int k = 0; k < 3; ++k) normals.col(triangles(k, t)) += n;
  }
  return normals;
}

render::TriangleMesh InEyeFrame(const Eigen::Isometry3d& T_E_S, const Eigen::Matrix3Xd& vertices_S,
                                const Eigen::Matrix3Xd& normals_S, const Eigen::Matrix2Xd& uvs_down,
                                const Eigen::Matrix3Xi& triangles) {
  render::TriangleMesh mesh;
  mesh.positions_C = (T_E_S * vertices_S).cast<float>();
  mesh.normals_C = (T_E_S.linear() * normals_S).cast<float>();
  mesh.uvs = uvs_down.cast<float>();
  mesh.triangles = triangles;
  return mesh;
}

// The sensor: linear radiance in [0, 1] to 8 bits, with Gaussian noise of
// sigma grey levels on each channel.
cv::Mat Expose(const cv::Mat& image, double sigma, uint64_t seed) {
  cv::Mat noise(image.size(), CV_32FC3);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, sigma);
  cv::Mat bgr;
  cv::Mat(image * 255.0 + noise).convertTo(bgr, CV_8UC3);
  return bgr;
}

// Everything in the scene that is drawn, in the scan frame.
struct DrawnScene {
  const SurfaceAssets& assets;
  const MountAssets& mount;
  Eigen::Matrix2Xd mount_uvs_down;
  Eigen::Matrix3Xd mount_normals;
  Eigen::Vector3d light_S;  // between the two cameras, as an endoscope's light
};

cv::Mat RenderEye(DistortedView* view, const Eigen::Isometry3d& T_E_S, const DrawnScene& scene,
                  const Eigen::Matrix3Xd& skin_S, const Eigen::Matrix3Xd& skin_normals_S) {
  render::Rasterizer& rasterizer = view->rasterizer();
  rasterizer.Clear(Eigen::Vector3f(0.05f, 0.04f, 0.055f));
  render::Light light;
  light.position_C = (T_E_S * scene.light_S).cast<float>();
  render::Material plastic;
  plastic.texture = &scene.mount.texture;
  plastic.ambient = 0.3f;
  plastic.diffuse = 0.7f;
  rasterizer.Draw(InEyeFrame(T_E_S, scene.mount.plate.vertices_m, scene.mount_normals, scene.mount_uvs_down,
                             scene.mount.plate.triangles),
                  plastic, light, 0);
  render::Material tissue;
  tissue.texture = &scene.assets.texture;
  tissue.ambient = 0.25f;
  tissue.diffuse = 0.75f;
  tissue.specular = 0.35f;  // wet tissue
  tissue.shininess = 40.0f;
  tissue.specular_color = Eigen::Vector3f(0.9f, 0.9f, 0.9f);
  rasterizer.Draw(InEyeFrame(T_E_S, skin_S, skin_normals_S, scene.assets.grid_uv, scene.assets.skin.triangles), tissue,
                  light, 1);
  return view->Resolve();
}

// Per-frame ground truth of one point set, accumulated row by row.
struct TrackedPoints {
  explicit TrackedPoints(int frames, Eigen::Index points)
      : xyz_C(frames * points * 3), uv_left(frames * points * 2), uv_right(frames * points * 2),
        visible_left(frames * points), visible_right(frames * points), count(points) {}
  void Record(int frame, const Eigen::Matrix3Xd& points_C, const StereoRig& rig, const std::vector<uint8_t>& vis_left,
              const std::vector<uint8_t>& vis_right) {
    const Eigen::Matrix3d R = rig.calibration.R;
    for (Eigen::Index p = 0; p < count; ++p) {
      const size_t row = size_t(frame) * count + p;
      const Eigen::Vector3d x = points_C.col(p);
      const Eigen::Vector2d left = stages::Project(rig.calibration.left, x);
      const Eigen::Vector2d right = stages::Project(rig.calibration.right, R * x + rig.calibration.T_m);
      for (int i = 0; i < 3; ++i) xyz_C[row * 3 + i] = x[i];
      for (int i = 0; i < 2; ++i) {
        uv_left[row * 2 + i] = left[i];
        uv_right[row * 2 + i] = right[i];
      }
      visible_left[row] = vis_left[p];
      visible_right[row] = vis_right[p];
    }
  }
  void Write(io::H5Writer* file, const std::string& group, int frames, const Eigen::Matrix3Xd& reference_S) const {
    const size_t n = static_cast<size_t>(count), f = static_cast<size_t>(frames);
    Eigen::MatrixXd reference = reference_S.transpose();
    file->WriteMatrix(group + "/X_S_m", reference);
    file->Write(group + "/xyz_C_m", xyz_C.data(), {f, n, 3});
    file->Write(group + "/uv_left_px", uv_left.data(), {f, n, 2});
    file->Write(group + "/uv_right_px", uv_right.data(), {f, n, 2});
    file->Write(group + "/visible_left", visible_left.data(), {f, n});
    file->Write(group + "/visible_right", visible_right.data(), {f, n});
  }
  std::vector<double> xyz_C, uv_left, uv_right;
  std::vector<uint8_t> visible_left, visible_right;
  Eigen::Index count;
};

Eigen::Matrix3Xd DeformAll(const HeartMotion& motion, const MotionState& state, const Eigen::Matrix3Xd& X_S) {
  Eigen::Matrix3Xd x(3, X_S.cols());
  for (Eigen::Index p = 0; p < X_S.cols(); ++p) x.col(p) = motion.Deform(X_S.col(p), state);
  return x;
}

// One eye's recording in the spec's lossless codec. Lossy codecs decode
// faster than HuffYUV (Motion JPEG at quality 95: about 1.3 ms a frame) but
// their halved chroma resolution moves the green markers' centroids by up to
// 0.45 px, beyond the 0.3 px the marker analysis of the ground truth is held
// to; FFV1 (0.4 MB a frame) decodes 3-5 times slower than HuffYUV.
class LosslessVideo {
 public:
  LosslessVideo(const std::string& path, const PhantomSpec& spec) {
    const cv::Size size(spec.width, spec.height);
    if (spec.video_codec == "raw") {
      raw_.emplace(path, size, spec.fps);
      return;
    }
    huffyuv_.open(path, cv::VideoWriter::fourcc('H', 'F', 'Y', 'U'), spec.fps, size);
    if (!huffyuv_.isOpened()) {
      throw Error("cannot open a video writer (HuffYUV)", path, "check that OpenCV was built with FFmpeg (Debian's is)");
    }
  }

  void Write(const cv::Mat& bgr) {
    if (raw_) {
      raw_->Write(bgr);
    } else {
      huffyuv_.write(bgr);
    }
  }

  void Close() {
    if (raw_) {
      raw_->Close();
    } else {
      huffyuv_.release();
    }
  }

 private:
  std::optional<UncompressedAviWriter> raw_;
  cv::VideoWriter huffyuv_;
};

void WriteChessboards(const PhantomSpec& spec, const StereoRig& rig, DistortedView* left, DistortedView* right,
                      const std::string& dir, io::H5Writer* truth) {
  const cv::Mat texture = Chessboard::Texture();
  const Eigen::Vector2d size = Chessboard::PrintSize_m();
  Eigen::Matrix3Xd corners(3, 4);
  corners << 0, size.x(), size.x(), 0,  //
      0, 0, size.y(), size.y(),         //
      0, 0, 0, 0;
  Eigen::Matrix2Xd uvs(2, 4);
  uvs << 0, 1, 1, 0,  //
      0, 0, 1, 1;
  Eigen::Matrix3Xi triangles(3, 2);
  triangles << 0, 0,  //
      1, 2,           //
      2, 3;
  const Eigen::Matrix3Xd normals = Eigen::Vector3d(0, 0, -1).replicate(1, 4);
  render::Material paper;
  paper.texture = &texture;
  paper.ambient = 0.45f;
  paper.diffuse = 0.55f;
  const std::vector<Eigen::Isometry3d> poses = SampleBoardPoses(spec, rig, spec.chessboard_pairs);
  std::vector<double> T_C_B;
  for (size_t b = 0; b < poses.size(); ++b) {
    const Eigen::Isometry3d T_R_B = rig.T_R_C() * poses[b];
    int eye = 0;
    for (auto [view, T_E_B] : {std::pair{left, poses[b]}, std::pair{right, T_R_B}}) {
      render::Rasterizer& rasterizer = view->rasterizer();
      rasterizer.Clear(Eigen::Vector3f(0.27f, 0.27f, 0.27f));
      rasterizer.Draw(InEyeFrame(T_E_B, corners, normals, uvs, triangles), paper, render::Light{}, 0);
      const cv::Mat image = Expose(view->Resolve(), spec.sensor_noise, spec.seed * 1000003 + 2 * b + eye);
      char name[64];
      std::snprintf(name, sizeof name, "/%s_%02zu.png", eye ? "right" : "left", b);
      cv::imwrite(dir + name, image);
      ++eye;
    }
    const Eigen::Matrix4d m = poses[b].matrix();
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) T_C_B.push_back(m(r, c));
    }
  }
  truth->Write("/calibration/T_C_B", T_C_B.data(), {poses.size(), 4, 4});
  const Eigen::MatrixXd corners_B = Chessboard::InnerCorners_B().transpose();
  truth->WriteMatrix("/calibration/inner_corners_B_m", corners_B);
}

// scan.xmf: the scan's per-phase node displacement on the phantom's mesh, for
// ParaView (one step per phase at its time in the cycle, the deformed
// positions as each step's geometry), its data in scan_series.h5 beside
// scan.h5. displacement: [phase][node][xyz], as scan.h5 holds it.
void WriteScanSeries(const std::string& out_dir, const sim::TetMesh& mesh, const std::vector<double>& displacement,
                     int phases, double period_s) {
  io::XdmfSeriesOptions options;
  options.deformed_geometry = true;
  options.h5_file_name = "scan_series.h5";
  io::XdmfTimeSeriesWriter series(out_dir + "/scan", mesh, options);
  const Eigen::Index values = 3 * Eigen::Index(mesh.num_nodes());
  for (int k = 0; k < phases; ++k) {
    series.Append(period_s * k / phases,
                  Eigen::Map<const Eigen::Matrix3Xd>(displacement.data() + k * values, 3, mesh.num_nodes()), {});
  }
  series.Close(true);
}

}  // namespace

std::string PhantomSummary::Describe() const {
  char text[512];
  std::snprintf(text, sizeof text,
                "scene: %s/scene.yaml\n"
                "mesh: %d nodes, %d tets (worst radius ratio %.2f); %d CT phases; %d fiducials\n"
                "video: %d stereo frames; %d chessboard pairs\n"
                "truth: period %.4f s, phase shift %.4f s (truth.h5)\n"
                "wall: %.1f s\n",
                out_dir.c_str(), nodes, tets, min_radius_ratio, phases, fiducials, frames, chessboard_pairs, period_s,
                phase_shift_s, wall_s);
  return text;
}

PhantomSummary GeneratePhantom(const PhantomSpec& spec, const std::string& out_dir, bool progress) {
  if (const std::string wrong = spec.Validate(); !wrong.empty()) {
    throw Error("invalid phantom: " + wrong, "dynaguide phantom", "correct the option");
  }
  const auto start = std::chrono::steady_clock::now();
  for (const char* sub : {"", "/ct", "/video", "/calibration", "/assets", "/truth"}) fs::create_directories(out_dir + sub);
  PhantomSummary summary;
  summary.out_dir = out_dir;

  Step(progress, "meshing");
  io::MeshReport mesh_report;
  const sim::TetMesh mesh =
      io::MeshTruncatedEllipsoid({spec.semi_axes_m, spec.centre_height_m, spec.tets}, &mesh_report);
  io::WriteMsh(mesh, out_dir + "/mesh.msh", 41);
  summary.nodes = mesh.num_nodes();
  summary.tets = mesh.num_tets();
  summary.min_radius_ratio = mesh_report.min_radius_ratio;

  const HeartGeometry geometry(spec);
  const StereoRig rig = MakeStereoRig(spec);
  const int frames = static_cast<int>(std::floor(spec.duration_s * spec.fps + 1e-9));
  const double period = spec.period_s();
  std::mt19937_64 rng(spec.seed * 0xE7037ED1A0B428DBULL + 5);
  const double phase_shift = std::uniform_real_distribution<double>(0.0, period)(rng);
  const HeartMotion motion(spec, phase_shift + frames / spec.fps + period);
  summary.frames = frames;
  summary.period_s = period;
  summary.phase_shift_s = phase_shift;
  summary.phases = spec.phases;

  Step(progress, "surface assets");
  const SurfaceAssets assets = MakeSurfaceAssets(spec, geometry, /*camera_azimuth_u=*/0.75);
  const MountAssets mount = MakeMountAssets(spec.seed);
  summary.fiducials = spec.fiducials;
  cv::imwrite(out_dir + "/assets/skin_texture.png", assets.texture);
  io::WriteObj(out_dir + "/assets/skin.obj", assets.skin, {1.0, "skin_texture.png"});
  for (size_t c = 0; c < assets.chamber_meshes.size(); ++c) {
    io::WriteObj(out_dir + "/assets/chamber_" + std::to_string(c) + ".obj", assets.chamber_meshes[c]);
  }

  Step(progress, "4D CT");
  {
    io::H5Writer scan(out_dir + "/scan.h5");
    const io::VolumeI16 grid = MakeCtGrid(spec);
    std::vector<double> displacement, fiducials, phase_values;
    const MotionState first_state = HeartMotion::NominalState(0.0);
    for (int k = 0; k < spec.phases; ++k) {
      const double phase = double(k) / spec.phases;
      const MotionState state = HeartMotion::NominalState(phase);
      phase_values.push_back(phase);
      for (int a = 0; a < mesh.num_nodes(); ++a) {
        const Eigen::Vector3d u = motion.Deform(mesh.X_m.col(a), state) - mesh.X_m.col(a);
        displacement.insert(displacement.end(), u.data(), u.data() + 3);
      }
      const Eigen::Matrix3Xd f = DeformAll(motion, state, assets.fiducials_S);
      for (Eigen::Index i = 0; i < f.cols(); ++i) fiducials.insert(fiducials.end(), f.col(i).data(), f.col(i).data() + 3);
      const io::VolumeI16 ct =
          SynthesizeCtPhase(grid, geometry, motion, state, assets.fiducials_S, spec.ct_noise_hu, spec.seed, k);
      char name[64];
      if (spec.writes_metaimage()) {
        std::snprintf(name, sizeof name, "/ct/phase_%02d.mhd", k);
        io::WriteMetaImage(out_dir + name, ct);
      }
      if (spec.writes_dicom()) {
        std::snprintf(name, sizeof name, "/ct/dicom/phase_%02d", k);
        WriteDicomPhase(ct, spec, k, out_dir + name);
      }
      std::snprintf(name, sizeof name, "/truth/dvf_phase_%02d.mha", k);
      io::WriteDisplacementField(out_dir + name, PhaseDisplacementField(grid, motion, first_state, state));
    }
    const size_t P = spec.phases, N = mesh.num_nodes(), F = assets.fiducials_S.cols();
    scan.Write("/phases/phase", phase_values.data(), {P});
    scan.Write("/phases/node_displacement_m", displacement.data(), {P, N, 3});
    scan.Write("/phases/fiducials_S_m", fiducials.data(), {P, F, 3});
    scan.WriteMatrix("/internal_points_S_m", Eigen::MatrixXd(assets.internal_points_S.transpose()));
    scan.WriteAttribute("/", "period_s", period);
    scan.WriteAttribute("/", "phases", spec.phases);
    WriteScanSeries(out_dir, mesh, displacement, spec.phases, period);
  }

  io::WriteStereoCalibration(out_dir + "/calibration.yaml", rig.calibration);
  DistortedView left_view(rig.calibration.left, spec.supersample);
  DistortedView right_view(rig.calibration.right, spec.supersample);
  io::H5Writer truth(out_dir + "/truth.h5");

  Step(progress, "calibration images");
  WriteChessboards(spec, rig, &left_view, &right_view, out_dir + "/calibration", &truth);
  summary.chessboard_pairs = spec.chessboard_pairs;

  Step(progress, "stereo video");
  DrawnScene scene{assets, mount, Eigen::Matrix2Xd(), Eigen::Matrix3Xd(), Eigen::Vector3d()};
  scene.mount_uvs_down = mount.plate.uvs;
  scene.mount_uvs_down.row(1) = 1 - mount.plate.uvs.row(1).array();
  scene.mount_normals = Eigen::Vector3d::UnitZ().replicate(1, mount.plate.num_vertices());
  scene.light_S = rig.T_C_S.inverse() * Eigen::Vector3d(0.5 * rig.calibration.T_m.norm(), 0, 0);
  const Eigen::Isometry3d T_R_S = rig.T_R_S();
  LosslessVideo left_video(out_dir + "/video/left.avi", spec);
  LosslessVideo right_video(out_dir + "/video/right.avi", spec);
  TrackedPoints fiducial_truth(frames, assets.fiducials_S.cols());
  TrackedPoints surface_truth(frames, assets.surface_points_S.cols());
  std::vector<double> internal_xyz, times, activation, sway;
  for (int j = 0; j < frames; ++j) {
    const double t_video = j / spec.fps;
    const MotionState state = motion.StateAt(t_video + phase_shift);
    times.push_back(t_video);
    activation.push_back(state.activation);
    sway.push_back(state.sway);
    const Eigen::Matrix3Xd skin = DeformAll(motion, state, assets.skin.vertices_m);
    const Eigen::Matrix3Xd normals = VertexNormals(skin, assets.skin.triangles);
    left_video.Write(Expose(RenderEye(&left_view, rig.T_C_S, scene, skin, normals), spec.sensor_noise,
                            spec.seed * 7919 + 2 * j));
    right_video.Write(Expose(RenderEye(&right_view, T_R_S, scene, skin, normals), spec.sensor_noise,
                             spec.seed * 7919 + 2 * j + 1));

    for (auto [points, truth_set] : {std::pair{&assets.fiducials_S, &fiducial_truth}, std::pair{&assets.surface_points_S, &surface_truth}}) {
      const Eigen::Matrix3Xd x_S = DeformAll(motion, state, *points);
      const Eigen::Matrix3Xd x_C = rig.T_C_S * x_S;
      truth_set->Record(j, x_C, rig, left_view.Visible(x_C, kVisibilityTolerance_m),
                        right_view.Visible(T_R_S * x_S, kVisibilityTolerance_m));
    }
    const Eigen::Matrix3Xd internal_C = rig.T_C_S * DeformAll(motion, state, assets.internal_points_S);
    internal_xyz.insert(internal_xyz.end(), internal_C.data(), internal_C.data() + internal_C.size());
    if (progress && (j + 1) % std::max(1, frames / 10) == 0) std::fprintf(stderr, "phantom: frame %d / %d\n", j + 1, frames);
  }
  left_video.Close();
  right_video.Close();

  const size_t J = frames;
  truth.WriteMatrix("/T_C_S", rig.T_C_S.matrix());
  truth.WriteScalar("/phase_shift_s", phase_shift);
  truth.WriteScalar("/period_s", period);
  truth.WriteScalar("/fps", spec.fps);
  truth.Write("/frames/time_s", times.data(), {J});
  truth.Write("/frames/activation", activation.data(), {J});
  truth.Write("/frames/sway", sway.data(), {J});
  fiducial_truth.Write(&truth, "/fiducials", frames, assets.fiducials_S);
  surface_truth.Write(&truth, "/surface_points", frames, assets.surface_points_S);
  truth.WriteMatrix("/internal_points/X_S_m", Eigen::MatrixXd(assets.internal_points_S.transpose()));
  truth.Write("/internal_points/xyz_C_m", internal_xyz.data(), {J, size_t(assets.internal_points_S.cols()), 3});
  std::vector<double> cycle_start, cycle_period, cycle_amplitude;
  for (const HeartMotion::Cycle& cycle : motion.cycles()) {
    cycle_start.push_back(cycle.start_s);
    cycle_period.push_back(cycle.period_s);
    cycle_amplitude.push_back(cycle.amplitude);
  }
  truth.Write("/cycles/start_s", cycle_start.data(), {cycle_start.size()});
  truth.Write("/cycles/period_s", cycle_period.data(), {cycle_period.size()});
  truth.Write("/cycles/amplitude", cycle_amplitude.data(), {cycle_amplitude.size()});
  truth.WriteAttribute("/", "preset", spec.preset);
  truth.WriteAttribute("/", "seed", static_cast<int64_t>(spec.seed));

  WriteSceneFile(out_dir + "/scene.yaml", spec, summary.frames, period);
  summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace dg::tools::phantom
