// The tracking front end on the phantom, against its exact ground truth:
// triangulated depth, temporal drift and fiducial positions.
#include <algorithm>
#include <map>

#include <Eigen/Dense>
#include <catch2/catch.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "sim/statistics.h"
#include "stages/track/feature_tracker.h"
#include "stages/track/fiducial_tracker.h"
#include "stages/track/marker_finder.h"
#include "tests/stages/track/rectified_phantom.h"
#include "tests/support/counting_mat_allocator.h"
#include "tests/support/temporary_folder.h"

namespace dg::stages {
namespace {

using testing::TruthTracks;

// The default preset, not `tiny`: the figures are for 640x480 with
// about 500 features. At tiny's 160x120 a pixel of disparity is four times the
// depth and at most about 300 features fit at the 7 px spacing, so the same
// bounds would mean something else (tiny serves the structural tests of
// `dynaguide track`). The drift is defined over three cardiac cycles at 90 bpm
// (2 s), so the video is as short as it can be: that and a margin for the
// cycle-to-cycle period variation.
constexpr double kDurationS = 2.2;

// The truth's surface samples visible in one frame, joined into small
// triangles (Delaunay in the left image): a material point inside one is the
// fixed barycentric blend of its corners, in 2D and in 3D. Long edges span
// the silhouette or gaps and are left out.
class TruthMesh {
 public:
  TruthMesh(const TruthTracks& truth, size_t frame, double max_edge_px) {
    const auto& uv = truth.uv_left_px[frame];
    cv::Subdiv2D subdiv(cv::Rect(-1000, -1000, 3000, 3000));
    std::map<std::pair<float, float>, int> index;
    for (size_t p = 0; p < uv.size(); ++p) {
      if (!truth.visible_left[frame][p]) continue;
      const cv::Point2f q(static_cast<float>(uv[p].x()), static_cast<float>(uv[p].y()));
      if (index.emplace(std::make_pair(q.x, q.y), static_cast<int>(p)).second) subdiv.insert(q);
    }
    std::vector<cv::Vec6f> triangles;
    subdiv.getTriangleList(triangles);
    for (const cv::Vec6f& t : triangles) {
      std::array<int, 3> corners;
      bool ok = true;
      for (int k = 0; k < 3 && ok; ++k) {
        const auto it = index.find({t[2 * k], t[2 * k + 1]});
        ok = it != index.end();
        if (ok) corners[k] = it->second;
      }
      for (int k = 0; k < 3 && ok; ++k) ok = (uv[corners[k]] - uv[corners[(k + 1) % 3]]).norm() <= max_edge_px;
      if (ok) triangles_.push_back(corners);
    }
    uv_ = uv;
  }

  // The triangle holding uv and the barycentric weights; false outside the mesh.
  bool Locate(const Eigen::Vector2d& uv, std::array<int, 3>* corners, Eigen::Vector3d* weights) const {
    for (const auto& t : triangles_) {
      const Eigen::Vector2d a = uv_[t[0]], b = uv_[t[1]], c = uv_[t[2]];
      Eigen::Matrix2d m;
      m << b - a, c - a;
      if (std::abs(m.determinant()) < 1e-12) continue;  // degenerate: three samples on a line
      const Eigen::Vector2d st = m.inverse() * (uv - a);
      const Eigen::Vector3d w(1 - st.sum(), st.x(), st.y());
      if (w.minCoeff() >= 0) {
        *corners = t;
        *weights = w;
        return true;
      }
    }
    return false;
  }

 private:
  std::vector<std::array<int, 3>> triangles_;
  std::vector<Eigen::Vector2d> uv_;
};

// The phantom is seen at 4 to 30 cm (the mount plane behind the heart included).
StereoMatcher::Options PhantomStereoOptions(const Triangulator& geometry) {
  StereoMatcher::Options options;
  options.min_disparity_px = std::max(0.0, std::floor(geometry.DisparityAtDepth(0.30)));
  options.max_disparity_px = std::ceil(geometry.DisparityAtDepth(0.04));
  return options;
}

struct TrackingRun {
  testing::RectifiedPhantom scene;
  TruthTracks truth, fiducials;
  std::vector<TrackFrame> frames;
  cv::Mat first_left_bgr;  // as recorded: colour, distorted
};

TrackingRun Run() {
  TrackingRun r;
  const dg::testing::TemporaryFolder folder("dg_track_test");
  const std::string& dir = folder.path();
  testing::GeneratePhantomScene(kDurationS, dir);
  r.scene = testing::LoadRectified(dir);
  r.truth = testing::ReadTruth(dir, "/surface_points");
  r.fiducials = testing::ReadTruth(dir, "/fiducials");
  cv::VideoCapture video(dir + "/video/left.avi");
  REQUIRE(video.read(r.first_left_bgr));
  FeatureTracker::Options options;
  options.stereo = PhantomStereoOptions(Triangulator(r.scene.calibration));
  FeatureTracker tracker(options, r.scene.calibration);
  for (size_t f = 0; f < r.scene.left_R.size(); ++f)
    r.frames.push_back(tracker.Process(r.scene.left_R[f], r.scene.right_R[f]));
  return r;
}

// Why this measure: the truth's surface samples are sparse, so each track's
// 3D point is compared with the true surface point seen at the same left
// pixel, interpolated within the small truth triangle around it (the surface
// between samples a few pixels apart is flat to well under 0.01 mm). This
// measures the error along the viewing ray, i.e. of the stereo disparity,
// without favouring the tracker's own choice of points.
void CheckSurfaceError(const TrackingRun& run) {
  std::vector<double> error_mm;
  size_t points = 0;
  for (size_t f = 0; f < run.frames.size(); ++f) {
    const TruthMesh mesh(run.truth, f, 25.0);
    for (const TrackedPoint& p : run.frames[f].points) {
      ++points;
      std::array<int, 3> corners;
      Eigen::Vector3d w;
      if (!mesh.Locate(p.uv_left_px, &corners, &w)) continue;
      Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
      for (int k = 0; k < 3; ++k) xyz += w[k] * run.truth.xyz_C_m[f][corners[k]];
      error_mm.push_back(1e3 * (p.xyz_C_m - xyz).norm());
    }
  }
  REQUIRE(!error_mm.empty());
  const double median = sim::Median(error_mm), p95 = sim::Quantile(error_mm, 0.95);
  WARN("frames " << run.frames.size() << ", points " << points << ", on the truth mesh " << error_mm.size()
                 << ", 3D error median " << median << " mm, p95 " << p95 << " mm");
  CHECK(run.frames.back().tracked >= 400);
  CHECK(median <= 0.5);
  CHECK(p95 <= 1.5);
}

// A track's material point is fixed by where it started: its barycentric
// weights in the first frame's truth triangle, applied to the same truth
// points in the last frame.
void CheckDrift(const TrackingRun& run) {
  const size_t last = run.frames.size() - 1;
  const TruthMesh first_mesh(run.truth, 0, 25.0);
  std::map<std::int64_t, Eigen::Vector2d> at_end;
  for (const TrackedPoint& p : run.frames[last].points) at_end[p.id] = p.uv_left_px;
  std::vector<double> drift_px;
  for (const TrackedPoint& p : run.frames[0].points) {
    const auto end = at_end.find(p.id);
    std::array<int, 3> corners;
    Eigen::Vector3d w;
    if (end == at_end.end() || !first_mesh.Locate(p.uv_left_px, &corners, &w)) continue;
    Eigen::Vector2d truth = Eigen::Vector2d::Zero();
    bool visible = true;
    for (int k = 0; k < 3; ++k) {
      truth += w[k] * run.truth.uv_left_px[last][corners[k]];
      visible = visible && run.truth.visible_left[last][corners[k]];
    }
    if (visible) drift_px.push_back((end->second - truth).norm());
  }
  REQUIRE(!drift_px.empty());
  const double median = sim::Median(drift_px);
  WARN("tracks from frame 0 to " << last << ": " << drift_px.size() << ", drift median " << median << " px, p95 "
                                 << sim::Quantile(drift_px, 0.95) << " px");
  CHECK(drift_px.size() >= 100);
  CHECK(median <= 0.5);
}

// The markers found automatically in the first recorded frame: one for each
// fiducial the truth shows there, at its projection. Returns them rectified,
// with the truth's index of each in `fiducial`.
std::vector<cv::Point2f> FoundFiducials(const TrackingRun& run, const Triangulator& geometry,
                                        std::vector<size_t>* fiducial) {
  const std::vector<Marker> markers = MarkerFinder({}).Find(run.first_left_bgr);
  const std::vector<Eigen::Vector2d>& truth = run.fiducials.uv_left_px[0];
  std::vector<cv::Point2f> start;
  std::vector<double> error_px;
  for (size_t i = 0; i < truth.size(); ++i) {
    if (!run.fiducials.visible_left[0][i]) continue;
    const auto distance = [&](const Marker& m) { return (Eigen::Vector2d(m.uv_px.x, m.uv_px.y) - truth[i]).norm(); };
    const auto nearest = std::min_element(markers.begin(), markers.end(),
                                          [&](const Marker& a, const Marker& b) { return distance(a) < distance(b); });
    REQUIRE(nearest != markers.end());
    error_px.push_back(distance(*nearest));
    Eigen::Vector2d uv_R;
    REQUIRE(geometry.LeftToRectified(Eigen::Vector2d(nearest->uv_px.x, nearest->uv_px.y), &uv_R));
    start.emplace_back(static_cast<float>(uv_R.x()), static_cast<float>(uv_R.y()));
    fiducial->push_back(i);
  }
  REQUIRE(!error_px.empty());
  WARN("markers found in the first frame: " << markers.size() << " for " << start.size()
                                            << " visible fiducials, error median " << sim::Median(error_px)
                                            << " px, max " << sim::Quantile(error_px, 1.0) << " px");
  CHECK(markers.size() == start.size());
  CHECK(sim::Median(error_px) <= 0.3);
  CHECK(sim::Quantile(error_px, 1.0) <= 0.3);
  return start;
}

// The fiducials, started from the markers found, tracked over all frames.
void CheckFiducials(const TrackingRun& run) {
  const TruthTracks& fiducials = run.fiducials;
  const Triangulator geometry(run.scene.calibration);
  std::vector<size_t> fiducial;
  const std::vector<cv::Point2f> start = FoundFiducials(run, geometry, &fiducial);
  FiducialTracker::Options options;
  options.stereo = PhantomStereoOptions(geometry);
  // Before the tracker: the images it keeps are freed through it.
  dg::testing::CountingMatAllocator mats;
  mats.frame_pixels = static_cast<long long>(run.scene.left_R[0].total());
  FiducialTracker tracker(options, start);
  std::vector<double> left_px, right_px;
  cv::Mat::setDefaultAllocator(&mats);
  long long frame_images_before_fourth = 0;
  for (size_t f = 0; f < run.scene.left_R.size(); ++f) {
    if (f == 3) frame_images_before_fourth = mats.frame_images.load();
    const std::vector<FiducialObservation> seen = tracker.Process(run.scene.left_R[f], run.scene.right_R[f]);
    for (size_t k = 0; k < seen.size(); ++k) {
      if (!seen[k].valid) continue;
      const size_t i = fiducial[k];
      const Eigen::Vector2d l(seen[k].uv_left_R_px.x, seen[k].uv_left_R_px.y);
      const Eigen::Vector2d r(seen[k].uv_right_R_px.x, seen[k].uv_right_R_px.y);
      if (fiducials.visible_left[f][i])
        left_px.push_back((geometry.LeftToDistorted(l) - fiducials.uv_left_px[f][i]).norm());
      if (fiducials.visible_right[f][i])
        right_px.push_back((geometry.RightToDistorted(r) - fiducials.uv_right_px[f][i]).norm());
    }
  }
  cv::Mat::setDefaultAllocator(nullptr);
  // The first three frames build the first frame's pyramid and the two
  // recent ones; later frames rebuild the recent ones in place, allocating
  // no frame-sized image (a pyramid's base).
  CHECK(mats.frame_images.load() - frame_images_before_fourth == 0);
  REQUIRE((!left_px.empty() && !right_px.empty()));
  const double left = sim::Median(left_px), right = sim::Median(right_px);
  WARN("fiducial observations " << left_px.size() << " left, " << right_px.size() << " right; median error " << left
                                << " px left, " << right << " px right");
  CHECK(left_px.size() >= 0.8 * fiducials.uv_left_px[0].size() * run.scene.left_R.size());
  CHECK(left <= 0.3);
  CHECK(right <= 0.3);
}

// One test case, so that the scene is generated and tracked once (CTest runs
// each test case in a process of its own).
TEST_CASE("feature and fiducial trackers: phantom 3D error, drift and fiducial error", "[stages][integration]") {
  const TrackingRun run = Run();
  CheckSurfaceError(run);
  CheckDrift(run);
  CheckFiducials(run);
}

}  // namespace
}  // namespace dg::stages
