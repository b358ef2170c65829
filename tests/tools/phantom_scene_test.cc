// The phantom scene checked against what independent tools measure in it:
// OpenCV's projection, marker centroids in the frames, bead centroids in the
// CT, and Gmsh's own reading of the mesh.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <queue>
#include <sstream>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <gmsh.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "io/h5_file.h"
#include "io/metaimage.h"
#include "io/scene.h"
#include "tests/support/temporary_folder.h"
#include "tools/phantom/phantom_generator.h"

namespace dg::tools::phantom {
namespace {

namespace fs = std::filesystem;

// The default preset, half a second long: one scene shared by the tests below.
const std::string& DefaultScene() {
  static const testing::TemporaryFolder folder("dg_phantom_test_default");
  static const std::string dir = [] {
    PhantomSpec spec = PresetSpec("default");
    spec.duration_s = 0.5;
    GeneratePhantom(spec, folder.path(), false);
    return folder.path();
  }();
  return dir;
}

struct Eye {
  cv::Mat K, D;
};

// The calibration as OpenCV itself reads it.
std::pair<Eye, Eye> ReadCalibration(const std::string& path, cv::Mat* R, cv::Mat* T) {
  cv::FileStorage file(path, cv::FileStorage::READ);
  REQUIRE(file.isOpened());
  Eye left, right;
  file["K1"] >> left.K;
  file["D1"] >> left.D;
  file["K2"] >> right.K;
  file["D2"] >> right.D;
  file["R"] >> *R;
  file["T"] >> *T;
  return {left, right};
}

std::vector<cv::Point3d> Points(const std::vector<double>& xyz, size_t frame, size_t count) {
  std::vector<cv::Point3d> points;
  for (size_t p = 0; p < count; ++p) {
    const double* x = &xyz[(frame * count + p) * 3];
    points.emplace_back(x[0], x[1], x[2]);
  }
  return points;
}

std::vector<cv::Mat> ReadVideo(const std::string& path) {
  cv::VideoCapture capture(path);
  REQUIRE(capture.isOpened());
  std::vector<cv::Mat> frames;
  for (cv::Mat frame; capture.read(frame);) frames.push_back(frame.clone());
  return frames;
}

// Green markers on red tissue: pixels whose green exceeds the other channels
// form blobs; within a blob each pixel weighs by how much of it the marker
// covers, its greenness over the blob's plateau (clipped to 1), so that the
// shading across the marker does not pull the centroid to its brighter side.
std::vector<cv::Point2d> MarkerCentroids(const cv::Mat& bgr) {
  cv::Mat greenness(bgr.size(), CV_32F);
  for (int r = 0; r < bgr.rows; ++r) {
    for (int c = 0; c < bgr.cols; ++c) {
      const cv::Vec3b px = bgr.at<cv::Vec3b>(r, c);
      greenness.at<float>(r, c) = std::max(0.f, float(px[1]) - std::max(float(px[0]), float(px[2])));
    }
  }
  cv::Mat mask = greenness > 12, labels;
  const int count = cv::connectedComponents(mask, labels, 8, CV_32S);
  std::vector<std::vector<cv::Point>> blobs(count);
  for (int r = 0; r < bgr.rows; ++r) {
    for (int c = 0; c < bgr.cols; ++c) blobs[labels.at<int>(r, c)].emplace_back(c, r);
  }
  std::vector<cv::Point2d> centroids;
  for (int label = 1; label < count; ++label) {
    std::vector<float> values;
    for (const cv::Point& p : blobs[label]) values.push_back(greenness.at<float>(p));
    std::sort(values.begin(), values.end());
    const float plateau = values[values.size() * 3 / 4];  // interior pixels dominate a disc's area
    cv::Point3d sum(0, 0, 0);
    for (const cv::Point& p : blobs[label]) {
      const double w = std::min(1.0f, greenness.at<float>(p) / plateau);
      sum += cv::Point3d(w * p.x, w * p.y, w);
    }
    centroids.emplace_back(sum.x / sum.z, sum.y / sum.z);
  }
  return centroids;
}

// The videos read back through OpenCV with the stated size, rate and length.
void CheckVideoReadsBack() {
  for (const char* eye : {"left", "right"}) {
    cv::VideoCapture capture(DefaultScene() + "/video/" + eye + ".avi");
    REQUIRE(capture.isOpened());
    REQUIRE(capture.get(cv::CAP_PROP_FRAME_WIDTH) == 640);
    REQUIRE(capture.get(cv::CAP_PROP_FRAME_HEIGHT) == 480);
    REQUIRE(capture.get(cv::CAP_PROP_FPS) == Approx(30));
    REQUIRE(ReadVideo(DefaultScene() + "/video/" + eye + ".avi").size() == 15);
  }
}

// Projecting the 3D truth with the written calibration through OpenCV's
// projectPoints gives the 2D truth.
void CheckTruthIsOpenCvProjection() {
  cv::Mat R, T;
  const auto [left, right] = ReadCalibration(DefaultScene() + "/calibration.yaml", &R, &T);
  const io::H5Reader truth(DefaultScene() + "/truth.h5");
  for (const std::string group : {"/fiducials", "/surface_points"}) {
    io::H5Shape shape;
    const std::vector<double> xyz = truth.Read<double>(group + "/xyz_C_m", &shape);
    const std::vector<double> uv_left = truth.Read<double>(group + "/uv_left_px");
    const std::vector<double> uv_right = truth.Read<double>(group + "/uv_right_px");
    const size_t frames = shape[0], count = shape[1];
    cv::Mat rvec_right;
    cv::Rodrigues(R, rvec_right);
    double worst = 0;
    for (size_t j = 0; j < frames; ++j) {
      std::vector<cv::Point2d> projected_left, projected_right;
      const std::vector<cv::Point3d> points = Points(xyz, j, count);
      cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), left.K, left.D, projected_left);
      cv::projectPoints(points, rvec_right, T, right.K, right.D, projected_right);
      for (size_t p = 0; p < count; ++p) {
        const size_t row = j * count + p;
        worst = std::max(worst, cv::norm(projected_left[p] - cv::Point2d(uv_left[2 * row], uv_left[2 * row + 1])));
        worst = std::max(worst, cv::norm(projected_right[p] - cv::Point2d(uv_right[2 * row], uv_right[2 * row + 1])));
      }
    }
    INFO(group);
    REQUIRE(worst < 0.01);
  }
}

// The markers that image analysis finds in the rendered, distorted, noisy
// frames sit where the 2D truth says, in both eyes.
void CheckMarkerCentroids() {
  const io::H5Reader truth(DefaultScene() + "/truth.h5");
  io::H5Shape shape;
  truth.Read<double>("/fiducials/xyz_C_m", &shape);
  const size_t count = shape[1];
  int matched = 0;
  std::vector<double> errors;
  for (const std::string eye : {"left", "right"}) {
    const std::vector<double> uv = truth.Read<double>("/fiducials/uv_" + eye + "_px");
    const std::vector<uint8_t> visible = truth.Read<uint8_t>("/fiducials/visible_" + eye);
    const std::vector<cv::Mat> frames = ReadVideo(DefaultScene() + "/video/" + eye + ".avi");
    for (size_t j = 0; j < frames.size(); ++j) {
      const std::vector<cv::Point2d> found = MarkerCentroids(frames[j]);
      for (size_t p = 0; p < count; ++p) {
        if (!visible[j * count + p]) continue;
        const cv::Point2d expected(uv[2 * (j * count + p)], uv[2 * (j * count + p) + 1]);
        double nearest = 1e9;
        for (const cv::Point2d& c : found) nearest = std::min(nearest, cv::norm(c - expected));
        REQUIRE(nearest < 3.0);  // every visible fiducial's marker is found
        errors.push_back(nearest);
        ++matched;
      }
    }
  }
  REQUIRE(matched >= 150);  // 6 fiducials x 15 frames x 2 eyes, nearly all visible
  std::sort(errors.begin(), errors.end());
  INFO("marker error median " << errors[errors.size() / 2] << " px, 95th percentile "
                               << errors[errors.size() * 95 / 100] << " px, max " << errors.back() << " px");
  REQUIRE(errors.back() <= 0.3);
}

// In every CT phase, the intensity-weighted centroid of each bright bead lies
// within half a voxel of that phase's fiducial position.
void CheckBeadCentroids() {
  const io::H5Reader scan(DefaultScene() + "/scan.h5");
  io::H5Shape shape;
  const std::vector<double> fiducials = scan.Read<double>("/phases/fiducials_S_m", &shape);
  const size_t phases = shape[0], count = shape[1];
  double worst_voxels = 0;
  for (size_t k = 0; k < phases; ++k) {
    char name[48];
    std::snprintf(name, sizeof name, "/ct/phase_%02zu.mhd", k);
    const io::VolumeI16 ct = io::ReadMetaImage<int16_t>(DefaultScene() + name);
    const double voxel = ct.spacing_m.x();
    for (size_t f = 0; f < count; ++f) {
      const Eigen::Vector3d expected(fiducials[(k * count + f) * 3], fiducials[(k * count + f) * 3 + 1],
                                     fiducials[(k * count + f) * 3 + 2]);
      // Weighted centroid of the voxels brighter than any tissue within 4 mm.
      const Eigen::Vector3d index = (expected - ct.origin_m) / voxel;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      double weight = 0;
      const int reach = static_cast<int>(std::ceil(0.004 / voxel));
      for (int dk = -reach; dk <= reach; ++dk) {
        for (int dj = -reach; dj <= reach; ++dj) {
          for (int di = -reach; di <= reach; ++di) {
            const int i = static_cast<int>(std::lround(index.x())) + di, j = static_cast<int>(std::lround(index.y())) + dj,
                      kk = static_cast<int>(std::lround(index.z())) + dk;
            if (i < 0 || j < 0 || kk < 0 || i >= ct.size.x() || j >= ct.size.y() || kk >= ct.size.z()) continue;
            const double w = ct.at(i, j, kk) - 600.0;  // above tissue (40), chambers (250) and mount (500)
            if (w <= 0) continue;
            sum += w * (ct.origin_m + voxel * Eigen::Vector3d(i, j, kk));
            weight += w;
          }
        }
      }
      REQUIRE(weight > 0);
      worst_voxels = std::max(worst_voxels, (sum / weight - expected).norm() / voxel);
    }
  }
  INFO("worst bead centroid error " << worst_voxels << " voxels");
  REQUIRE(worst_voxels <= 0.5);
}

// Gmsh reads the mesh with every tetrahedron positively oriented, and the
// fixed group ("base") lies on the mount plane.
void CheckMeshInGmsh() {
  gmsh::initialize(0, nullptr, false);
  gmsh::option::setNumber("General.Terminal", 0);
  gmsh::open(DefaultScene() + "/mesh.msh");
  std::vector<std::size_t> node_tags;
  std::vector<double> coords, parametric;
  gmsh::model::mesh::getNodes(node_tags, coords, parametric);
  std::map<std::size_t, Eigen::Vector3d> nodes;
  for (size_t n = 0; n < node_tags.size(); ++n) nodes[node_tags[n]] = {coords[3 * n], coords[3 * n + 1], coords[3 * n + 2]};
  std::vector<std::size_t> tets, tet_nodes;
  gmsh::model::mesh::getElementsByType(4, tets, tet_nodes);
  REQUIRE(tets.size() > 6000);
  for (size_t e = 0; e < tets.size(); ++e) {
    const Eigen::Vector3d x0 = nodes[tet_nodes[4 * e]];
    const double six_volume = (nodes[tet_nodes[4 * e + 1]] - x0).cross(nodes[tet_nodes[4 * e + 2]] - x0).dot(nodes[tet_nodes[4 * e + 3]] - x0);
    REQUIRE(six_volume > 0);
  }
  gmsh::vectorpair groups;
  gmsh::model::getPhysicalGroups(groups);
  bool found_base = false;
  for (const auto& [dim, tag] : groups) {
    std::string name;
    gmsh::model::getPhysicalName(dim, tag, name);
    if (name != "base") continue;
    found_base = true;
    std::vector<std::size_t> base_nodes;
    std::vector<double> base_coords;
    gmsh::model::mesh::getNodesForPhysicalGroup(dim, tag, base_nodes, base_coords);
    REQUIRE(base_nodes.size() > 20);
    for (size_t n = 0; n < base_nodes.size(); ++n) REQUIRE(std::abs(base_coords[3 * n + 2]) < 1e-9);
  }
  gmsh::finalize();
  REQUIRE(found_base);
}

// OpenCV finds the chessboard in every calibration image, and its refined
// corners lie where the true board pose and the true cameras put them.
void CheckChessboards() {
  cv::Mat R, T;
  const auto [left, right] = ReadCalibration(DefaultScene() + "/calibration.yaml", &R, &T);
  const io::H5Reader truth(DefaultScene() + "/truth.h5");
  io::H5Shape shape;
  const std::vector<double> poses = truth.Read<double>("/calibration/T_C_B", &shape);
  const Eigen::MatrixXd corners_B = truth.ReadMatrix("/calibration/inner_corners_B_m");
  std::vector<double> errors;
  for (size_t b = 0; b < shape[0]; ++b) {
    cv::Mat T_C_B(4, 4, CV_64F, const_cast<double*>(&poses[16 * b]));
    for (const std::string eye : {"left", "right"}) {
      char name[64];
      std::snprintf(name, sizeof name, "/calibration/%s_%02zu.png", eye.c_str(), b);
      const cv::Mat image = cv::imread(DefaultScene() + name, cv::IMREAD_GRAYSCALE);
      std::vector<cv::Point2f> found;
      INFO(name);
      REQUIRE(cv::findChessboardCorners(image, cv::Size(9, 6), found));
      cv::cornerSubPix(image, found, cv::Size(5, 5), cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-4));
      cv::Mat pose = T_C_B.clone();
      if (eye == "right") {
        cv::Mat T_R_C = cv::Mat::eye(4, 4, CV_64F);
        R.copyTo(T_R_C(cv::Rect(0, 0, 3, 3)));
        T.reshape(1, 3).copyTo(T_R_C(cv::Rect(3, 0, 1, 3)));
        pose = T_R_C * T_C_B;
      }
      std::vector<cv::Point3d> points;
      for (Eigen::Index k = 0; k < corners_B.rows(); ++k) {
        cv::Mat p = pose * (cv::Mat_<double>(4, 1) << corners_B(k, 0), corners_B(k, 1), corners_B(k, 2), 1);
        points.emplace_back(p.at<double>(0), p.at<double>(1), p.at<double>(2));
      }
      std::vector<cv::Point2d> projected;
      const Eye& camera = eye == "left" ? left : right;
      cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), camera.K, camera.D, projected);
      // Detection order may start from either end of the board.
      double forward = 0, backward = 0;
      const size_t n = found.size();
      for (size_t k = 0; k < n; ++k) {
        forward += cv::norm(cv::Point2d(found[k]) - projected[k]);
        backward += cv::norm(cv::Point2d(found[k]) - projected[n - 1 - k]);
      }
      for (size_t k = 0; k < n; ++k) {
        errors.push_back(cv::norm(cv::Point2d(found[k]) - projected[forward <= backward ? k : n - 1 - k]));
      }
    }
  }
  std::sort(errors.begin(), errors.end());
  INFO("corner error median " << errors[errors.size() / 2] << " px, max " << errors.back() << " px");
  REQUIRE(errors[errors.size() / 2] < 0.1);
  REQUIRE(errors.back() < 0.5);
}

// The scene file names every file of the scene, and the scene reader finds them all.
void CheckSceneFile() {
  const io::Scene scene = io::ReadScene(DefaultScene() + "/scene.yaml");
  REQUIRE(scene.preoperative->phases == 20);
  REQUIRE(scene.preoperative->ct_volumes.size() == 20);
  REQUIRE(scene.preoperative->period_s == Approx(60.0 / 90));
  REQUIRE(scene.overlays->internal_meshes.size() == 2);
  REQUIRE(scene.video.fps == 30);
  REQUIRE(scene.video.frames == 15);
  REQUIRE(scene.mesh.fixed_set == "base");
  REQUIRE(!scene.truth.empty());
}

}  // namespace

// One process generates the default scene once (half a second of video) and
// every check below reads it; CTest runs each test case in its own process.
TEST_CASE("phantom: default scene agrees with independent measurements", "[tools][integration]") {
  SECTION("the videos read back through OpenCV with their size, rate and length") { CheckVideoReadsBack(); }
  SECTION("OpenCV's projectPoints of the 3D truth gives the 2D truth") { CheckTruthIsOpenCvProjection(); }
  SECTION("marker centroids found in the frames match the 2D truth") { CheckMarkerCentroids(); }
  SECTION("CT bead centroids match the per-phase fiducials") { CheckBeadCentroids(); }
  SECTION("Gmsh reads the mesh oriented, its fixed group on the mount") { CheckMeshInGmsh(); }
  SECTION("OpenCV finds every chessboard where the true pose puts it") { CheckChessboards(); }
  SECTION("the scene file names every file, and the scene reader finds them") { CheckSceneFile(); }
}

namespace {

std::map<std::string, std::string> ReadTree(const std::string& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    std::ifstream file(entry.path(), std::ios::binary);
    std::stringstream bytes;
    bytes << file.rdbuf();
    files[fs::relative(entry.path(), dir).string()] = bytes.str();
  }
  return files;
}

}  // namespace

// The same seed writes the same bytes in every file; another seed changes the video and truth.
TEST_CASE("phantom: deterministic from its seed", "[tools][integration]") {
  const testing::TemporaryFolder folder("dg_phantom_test_seed");
  const fs::path base = folder.path();
  PhantomSpec spec = PresetSpec("tiny");
  GeneratePhantom(spec, (base / "a").string(), false);
  GeneratePhantom(spec, (base / "b").string(), false);
  spec.seed = 2;
  GeneratePhantom(spec, (base / "c").string(), false);
  const auto a = ReadTree((base / "a").string()), b = ReadTree((base / "b").string()), c = ReadTree((base / "c").string());
  REQUIRE(a.size() > 40);
  for (const auto& [name, bytes] : a) {
    INFO(name);
    REQUIRE(b.count(name));
    REQUIRE((bytes == b.at(name)));  // parenthesised: no byte dump on failure
  }
  for (const char* name : {"truth.h5", "video/left.avi", "ct/phase_00.raw", "assets/skin_texture.png"}) {
    INFO(name);
    REQUIRE((a.at(name) != c.at(name)));
  }
}

}  // namespace dg::tools::phantom
