// The preop steps on synthetic images with analytic answers, and their
// errors on bad input.
#include <cmath>
#include <numbers>
#include <string>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>

#include "sim/error.h"
#include "stages/preop/segment/segmentation.h"
#include "stages/preop/segment/surface_extraction.h"

namespace dg::stages::preop {
namespace {

using Catch::Matchers::Contains;

// A CT of n^3 voxels of 1 mm, air with a ball of tissue (40 HU) of the given
// radius about the grid's centre; the direction maps voxel axes into S.
io::CtImage BallCt(int n, double radius_vox, const Eigen::Matrix3d& direction = Eigen::Matrix3d::Identity()) {
  io::CtImage ct;
  ct.size.setConstant(n);
  ct.spacing_m.setConstant(1e-3);
  ct.origin_m = Eigen::Vector3d(0.01, -0.02, 0.03);
  ct.direction = direction;
  ct.source = "synthetic ball";
  ct.values.resize(ct.num_voxels());
  const double c = 0.5 * (n - 1);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        ct.values[ct.Index(i, j, k)] = Eigen::Vector3d(i - c, j - c, k - c).norm() <= radius_vox ? 40.0f : -1000.0f;
  return ct;
}

TEST_CASE("preop segment: a ball's surface is a sphere of its radius, outward in any frame", "[unit]") {
  constexpr int kN = 24;
  constexpr double kRadius = 8;
  // A mirroring direction (determinant -1, as a flipped DICOM axis) as well
  // as the identity: the triangles must face outwards in S either way.
  Eigen::Matrix3d mirror;
  mirror << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  for (const Eigen::Matrix3d& direction : {Eigen::Matrix3d(Eigen::Matrix3d::Identity()), mirror}) {
    const io::CtImage ct = BallCt(kN, kRadius, direction);
    const Segmentation s = Segment(ct, SegmentationOptions{});
    REQUIRE(s.internal.empty());
    REQUIRE(s.mount.Count() == 0);
    SurfaceReport report;
    SurfaceOptions options;
    options.target_triangles = 1000;
    const io::SurfaceMesh surface = ExtractSurface(s.organ, options, &report);
    CHECK(surface.num_triangles() <= 1000);
    const Eigen::Vector3d centre = ct.PointOf(0.5 * (kN - 1), 0.5 * (kN - 1), 0.5 * (kN - 1));
    double worst_m = 0;
    for (int v = 0; v < surface.num_vertices(); ++v) {
      worst_m = std::max(worst_m, std::abs((surface.vertices_m.col(v) - centre).norm() - kRadius * 1e-3));
    }
    // A voxelised ball of radius 8 voxels: its surface within 0.5 voxel of the sphere.
    CHECK(worst_m < 0.5e-3);
    const double sphere_m3 = 4.0 / 3.0 * std::numbers::pi * std::pow(kRadius * 1e-3, 3);
    CHECK(report.enclosed_volume_m3 == Approx(sphere_m3).epsilon(0.05));
    CHECK(SixEnclosedVolume(surface) > 0);
    // Outward: each triangle's normal points away from the centre.
    for (int t = 0; t < surface.num_triangles(); ++t) {
      const Eigen::Vector3d a = surface.vertices_m.col(surface.triangles(0, t));
      const Eigen::Vector3d b = surface.vertices_m.col(surface.triangles(1, t));
      const Eigen::Vector3d c = surface.vertices_m.col(surface.triangles(2, t));
      REQUIRE((b - a).cross(c - a).dot((a + b + c) / 3 - centre) > 0);
    }
  }
}

TEST_CASE("preop segment: a threshold range that finds nothing is a named error", "[unit]") {
  SegmentationOptions options;
  options.organ_hu = {2000, 2500};
  REQUIRE_THROWS_WITH(Segment(BallCt(12, 4), options), Contains("no organ voxel") && Contains("[2000, 2500] HU") &&
                                                            Contains("synthetic ball") && Contains("fix:"));
}

TEST_CASE("preop segment: a label map on another grid is a named error", "[unit]") {
  const io::CtImage ct = BallCt(12, 4);
  io::CtImage labels = BallCt(12, 4);
  labels.source = "labels.nrrd";
  labels.origin_m.x() += 1e-3;
  REQUIRE_THROWS_WITH(Segment(ct, labels, SegmentationOptions{}),
                      Contains("label map on another grid") && Contains("labels.nrrd") && Contains("resample"));
  labels = BallCt(13, 4);
  REQUIRE_THROWS_WITH(Segment(ct, labels, SegmentationOptions{}), Contains("13 x 13 x 13"));
}

TEST_CASE("preop segment: a label absent from the map is a named error", "[unit]") {
  const io::CtImage ct = BallCt(12, 4);
  io::CtImage labels = ct;
  labels.source = "labels.nii.gz";
  for (float& v : labels.values) v = v > 0 ? 1.0f : 0.0f;  // organ 1, no mount
  SegmentationOptions options;
  options.mount_label = 0;
  const Segmentation s = Segment(ct, labels, options);
  CHECK(s.organ.Count() == static_cast<std::size_t>(std::count(labels.values.begin(), labels.values.end(), 1.0f)));

  options.internal_labels = {7};
  REQUIRE_THROWS_WITH(Segment(ct, labels, options), Contains("label 7 is on no voxel") && Contains("labels.nii.gz"));
  options.internal_labels = {};
  options.mount_label = 2;
  REQUIRE_THROWS_WITH(Segment(ct, labels, options), Contains("label 2 is on no voxel"));
  options.organ_label = 3;
  REQUIRE_THROWS_WITH(Segment(ct, labels, options), Contains("label 3 is on no voxel"));
}

TEST_CASE("preop segment: a label map gives the organ with its internal structures, and the mount", "[unit]") {
  const io::CtImage ct = BallCt(16, 6);
  io::CtImage labels = ct;
  std::size_t organ = 0, inner = 0;
  const double c = 7.5;
  for (int k = 0; k < 16; ++k)
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 16; ++i) {
        float& label = labels.values[labels.Index(i, j, k)];
        const double r = Eigen::Vector3d(i - c, j - c, k - c).norm();
        label = k == 0 ? 2.0f : r <= 2.5 ? 3.0f : r <= 6 ? 1.0f : 0.0f;
        organ += r <= 6 && k > 0;
        inner += r <= 2.5 && k > 0;
      }
  SegmentationOptions options;
  options.internal_labels = {3};
  const Segmentation s = Segment(ct, labels, options);
  CHECK(s.organ.Count() == organ);  // the internal structure is part of the solid
  REQUIRE(s.internal.size() == 1);
  CHECK(s.internal[0].Count() == inner);
  CHECK(s.mount.Count() == 16u * 16u);
  CHECK(s.report.organ_voxels_dropped == 0);
}

TEST_CASE("preop segment: invalid options are refused by name", "[unit]") {
  SegmentationOptions segmentation;
  segmentation.mount_hu = {600, 400};
  CHECK_THAT(segmentation.Validate(), Contains("mount_hu"));
  segmentation = {};
  segmentation.internal_labels = {1};
  CHECK_THAT(segmentation.Validate(), Contains("distinct"));
  SurfaceOptions surface;
  surface.smoothing_pass_band = 0;
  CHECK_THAT(surface.Validate(), Contains("smoothing_pass_band"));
  REQUIRE_THROWS_AS(ExtractSurface(VoxelMask::OnGridOf(BallCt(4, 1)), SurfaceOptions{}), Error);
}

}  // namespace
}  // namespace dg::stages::preop
