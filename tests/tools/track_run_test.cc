// `dynaguide track` on the tiny phantom: the saved tracks have the documented
// structure, persistent ids, and the same values in HDF5 and CSV.
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <unistd.h>

#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "io/h5_file.h"
#include "sim/error.h"
#include "tools/phantom/phantom_generator.h"
#include "tools/phantom/phantom_spec.h"
#include "tools/track/track_run.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;

// The tiny phantom, once per process (test processes run concurrently), removed at exit.
struct TemporaryScene {
  std::string dir = (fs::temp_directory_path() / ("dg_track_run_test_" + std::to_string(::getpid()))).string();
  TemporaryScene() {
    fs::remove_all(dir);
    phantom::GeneratePhantom(phantom::PresetSpec("tiny"), dir, false);
  }
  ~TemporaryScene() { fs::remove_all(dir); }
};

const std::string& TinyScene() {
  static const TemporaryScene scene;
  return scene.dir;
}

std::vector<std::vector<std::string>> ReadCsv(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::vector<std::string>> rows;
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string>& row = rows.emplace_back();
    std::stringstream fields(line);
    for (std::string field; std::getline(fields, field, ',');) row.push_back(field);
  }
  return rows;
}

TEST_CASE("track: a frame range of the tiny phantom to HDF5 and CSV", "[tools][integration]") {
  TrackRunOptions options;
  options.input.scene = TinyScene() + "/scene.yaml";
  options.out_h5 = TinyScene() + "/tracks.h5";
  options.out_csv = TinyScene() + "/tracks.csv";
  options.first_frame = 2;
  options.end_frame = 12;
  const TrackRunSummary summary = RunTrack(options);
  REQUIRE(summary.frames == 10);
  REQUIRE(summary.rows > 0);

  const io::H5Reader h5(options.out_h5);
  const size_t n = summary.rows;
  for (const char* column : {"frame", "t_s", "id", "kind", "quality"})
    CHECK(h5.Shape(std::string("/tracks/") + column) == io::H5Shape{n});
  for (const char* column : {"uv_left_R_px", "uv_right_R_px", "uv_left_px", "uv_right_px"})
    CHECK(h5.Shape(std::string("/tracks/") + column) == io::H5Shape{n, 2});
  CHECK(h5.Shape("/tracks/xyz_C_m") == io::H5Shape{n, 3});
  CHECK(h5.ReadAttribute<std::int64_t>("/tracks", "frames") == 10);

  const std::vector<std::int32_t> frame = h5.Read<std::int32_t>("/tracks/frame");
  const std::vector<std::int32_t> id = h5.Read<std::int32_t>("/tracks/id");
  const std::vector<double> xyz = h5.Read<double>("/tracks/xyz_C_m");
  const std::vector<double> uv_right = h5.Read<double>("/tracks/uv_right_px");
  std::map<int, std::set<int>> ids_of_frame;
  for (size_t i = 0; i < n; ++i) {
    REQUIRE(frame[i] >= 2);
    REQUIRE(frame[i] < 12);
    CHECK(ids_of_frame[frame[i]].insert(id[i]).second);  // an id once per frame
    CHECK(xyz[3 * i + 2] > 0);                           // in front of the camera
  }
  REQUIRE(ids_of_frame.size() == 10);
  // Persistent ids: most points of a frame were tracked, under the same id, in the one before.
  for (int f = 3; f < 12; ++f) {
    int kept = 0;
    for (int i : ids_of_frame[f]) kept += ids_of_frame[f - 1].count(i);
    CHECK(kept >= 0.8 * ids_of_frame[f].size());
  }

  const std::vector<std::vector<std::string>> csv = ReadCsv(options.out_csv);
  REQUIRE(csv.size() == n + 1);
  CHECK(csv[0][0] == "frame");
  CHECK(csv[0].size() == 16);
  for (size_t i = 0; i < n; ++i) {
    const std::vector<std::string>& row = csv[i + 1];
    REQUIRE(row.size() == 16);
    CHECK(std::stoi(row[0]) == frame[i]);
    CHECK(std::stoi(row[2]) == id[i]);
    CHECK(std::stod(row[10]) == Approx(uv_right[2 * i]).epsilon(1e-8));
    CHECK(std::stod(row[14]) == Approx(xyz[3 * i + 2]).epsilon(1e-8));
  }
}

TEST_CASE("track: a single image pair with a calibration, and an empty frame range refused", "[tools][integration]") {
  const std::string dir = TinyScene();
  for (const char* eye : {"left", "right"}) {
    cv::VideoCapture video(dir + "/video/" + eye + ".avi");
    cv::Mat image;
    REQUIRE(video.read(image));
    REQUIRE(cv::imwrite(dir + "/" + eye + ".png", image));
  }
  TrackRunOptions options;
  options.input.left = dir + "/left.png";
  options.input.right = dir + "/right.png";
  options.input.calibration = dir + "/calibration.yaml";
  options.out_h5 = dir + "/pair.h5";
  const TrackRunSummary summary = RunTrack(options);
  CHECK(summary.frames == 1);
  CHECK(summary.rows > 0);
  CHECK(io::H5Reader(options.out_h5).Shape("/tracks/xyz_C_m") == io::H5Shape{summary.rows, 3});

  options.first_frame = 1;
  CHECK_THROWS_WITH(RunTrack(options), Catch::Contains("frame range"));
}

}  // namespace
}  // namespace dg::tools
