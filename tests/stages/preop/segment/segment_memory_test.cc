// Automatic segmentation's peak memory on a CT with thousands of separate
// components in every HU range, as real CTs have (3,600-21,700 were counted on
// patients' scans): the components are labels of one image, not a mask each.
#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>

#include <catch2/catch.hpp>

#include "stages/preop/segment/segmentation.h"

namespace dg::stages::preop {
namespace {

// A field of /proc/self/status in bytes (VmRSS: resident now; VmHWM: the
// peak since the process started or since ResetPeakRss()).
std::size_t StatusBytes(const std::string& field) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind(field + ":", 0) == 0) return 1024 * std::stoull(line.substr(field.size() + 1));  // kB
  }
  FAIL("no " << field << " in /proc/self/status");
  return 0;
}

// Writing 5 to clear_refs sets VmHWM back to VmRSS (Linux 4.0 and later), so
// earlier tests in this process do not count.
void ResetPeakRss() {
  std::ofstream clear("/proc/self/clear_refs");
  clear << "5";
  clear.close();
  REQUIRE(clear.good());
}

// 256 x 256 x 128 voxels of 1 mm: a mount slab (500 HU) under a box of tissue
// (40 HU) holding two large chambers (250 HU) and about 15,000 chamber-range
// specks of 2^3 voxels (under the 50 mm^3 kept), beads (3000 HU) on top, and
// in the air around it about 7,000 cubes of 3^3 voxels alternately in the
// tissue's and the mount's range (each a component of its own; 3 voxels wide,
// they survive the organ's opening).
io::CtImage ManyComponentsCt() {
  io::CtImage ct;
  ct.size = Eigen::Vector3i(256, 256, 128);
  ct.spacing_m.setConstant(1e-3);
  ct.source = "synthetic CT of many components";
  ct.values.assign(ct.num_voxels(), -1000.0f);
  auto in_organ = [](int i, int j, int k) { return i >= 28 && i < 228 && j >= 28 && j < 228 && k >= 8 && k < 108; };
  // Whether a cube of 3 voxels from (i, j, k) comes within 2 voxels of the organ.
  auto near_organ = [](int i, int j, int k) {
    return i + 2 >= 26 && i < 230 && j + 2 >= 26 && j < 230 && k + 2 >= 6 && k < 110;
  };
  for (int k = 0; k < 128; ++k)
    for (int j = 0; j < 256; ++j)
      for (int i = 0; i < 256; ++i) {
        float& hu = ct.values[ct.Index(i, j, k)];
        if (k < 8) {
          hu = 500;
        } else if (in_organ(i, j, k)) {
          const bool speck = i % 6 < 2 && j % 6 < 2 && k % 6 < 2 && in_organ(i - 3, j - 3, k - 3) &&
                             in_organ(i + 3, j + 3, k + 3);
          const bool chamber = (i >= 60 && i < 90 && j >= 60 && j < 90 && k >= 30 && k < 60) ||
                               (i >= 150 && i < 170 && j >= 150 && j < 170 && k >= 40 && k < 60);
          hu = speck || chamber ? 250 : 40;
        } else if (i % 6 < 3 && j % 6 < 3 && k % 6 < 3 && k >= 12 && !near_organ(i / 6 * 6, j / 6 * 6, k / 6 * 6)) {
          hu = (i / 6 + j / 6 + k / 6) % 2 ? 40 : 500;
        }
      }
  for (int b = 0; b < 20; ++b) ct.values[ct.Index(40 + 8 * b, 128, 108)] = 3000;
  return ct;
}

TEST_CASE("preop segment: peak memory stays under 6 times the CT's size with thousands of components",
          "[integration]") {
  const io::CtImage ct = ManyComponentsCt();
  const double ct_bytes = static_cast<double>(ct.values.size() * sizeof(float));
  ResetPeakRss();
  const std::size_t before = StatusBytes("VmRSS");
  const auto start = std::chrono::steady_clock::now();
  const Segmentation s = Segment(ct, SegmentationOptions{});
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double growth = static_cast<double>(StatusBytes("VmHWM") - before);
  std::printf("segmentation of %d x %d x %d voxels: %.1f s, peak RSS growth %.0f MB = %.2f x the CT's %.0f MB; %s\n",
              ct.size.x(), ct.size.y(), ct.size.z(), wall_s, growth / 1e6, growth / ct_bytes, ct_bytes / 1e6,
              s.report.Describe().c_str());
  // The components were there to find: thousands in the organ's range, in
  // the internal range, and all but the two chambers dropped.
  CHECK(s.report.organ_components > 3000);
  CHECK(s.report.internal_components > 10000);
  CHECK(s.internal.size() == 2);
  CHECK(s.report.internal_components_dropped == s.report.internal_components - 2);
  // The organ is the tissue box (200 x 200 x 100 voxels), the mount the slab.
  CHECK(s.report.organ_voxels == Approx(200.0 * 200 * 100).epsilon(0.01));
  CHECK(s.report.mount_voxels == 256u * 256u * 8u);
  CHECK(growth < 6 * ct_bytes);
}

}  // namespace
}  // namespace dg::stages::preop
