// The preop steps on synthetic images with analytic answers, and their
// errors on bad input.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Dense>  // before ITK, whose bundled Eigen would otherwise compile against ours
#include <Eigen/Geometry>
#include <catch2/catch.hpp>

#include <itkBinaryBallStructuringElement.h>
#include <itkBinaryFillholeImageFilter.h>
#include <itkBinaryMorphologicalClosingImageFilter.h>
#include <itkImage.h>

#include "sim/error.h"
#include "stages/preop/segment/segmentation.h"
#include "stages/preop/segment/segmentation_presets.h"
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

// A ball of radius 20 mm on a grid of 0.5 mm voxels, for a surface of 500
// triangles: flying edges on every voxel would make about 60000 triangles
// (two per voxel face of the staircase); on blocks of 2 x 2 x 2 voxels it
// makes 15000, and the surface still lies on the sphere, within 0.3 mm.
TEST_CASE("preop segment: a fine scan's surface is extracted from blocks of voxels, on the sphere", "[unit]") {
  VoxelMask mask;
  mask.size.setConstant(90);
  mask.spacing_m.setConstant(0.5e-3);
  mask.inside.assign(mask.num_voxels(), 0);
  const Eigen::Vector3d centre = mask.PointOf(44.5, 44.5, 44.5);
  for (int k = 0; k < 90; ++k)
    for (int j = 0; j < 90; ++j)
      for (int i = 0; i < 90; ++i) mask.inside[mask.Index(i, j, k)] = (mask.PointOf(i, j, k) - centre).norm() <= 0.02;
  SurfaceOptions options;
  options.target_triangles = 500;
  SurfaceReport report;
  const io::SurfaceMesh surface = ExtractSurface(mask, options, &report);
  INFO("flying edges made " << report.extracted_triangles << " triangles");
  CHECK(report.extracted_triangles < 30000);
  double worst_m = 0;
  for (int v = 0; v < surface.num_vertices(); ++v) {
    worst_m = std::max(worst_m, std::abs((surface.vertices_m.col(v) - centre).norm() - 0.02));
  }
  INFO("worst distance from the sphere " << worst_m * 1e3 << " mm");
  CHECK(worst_m < 0.6e-3);
  const double sphere_m3 = 4.0 / 3.0 * std::numbers::pi * std::pow(0.02, 3);
  CHECK(report.enclosed_volume_m3 == Approx(sphere_m3).epsilon(0.03));
}

// A cube of side 30 mm on a grid of 0.7 x 0.6 x 2 mm voxels, pierced along
// x by a tunnel of radius 4 mm.
VoxelMask PiercedCube() {
  VoxelMask mask;
  mask.spacing_m = Eigen::Vector3d(0.7e-3, 0.6e-3, 2e-3);
  mask.size = Eigen::Vector3i(70, 80, 30);
  mask.origin_m = Eigen::Vector3d(-0.02, 0.01, 0.3);
  mask.inside.assign(mask.num_voxels(), 0);
  const Eigen::Vector3d centre = mask.PointOf(35, 40, 15);
  for (int k = 0; k < mask.size.z(); ++k)
    for (int j = 0; j < mask.size.y(); ++j)
      for (int i = 0; i < mask.size.x(); ++i) {
        const Eigen::Vector3d d = mask.PointOf(i, j, k) - centre;
        mask.inside[mask.Index(i, j, k)] = d.cwiseAbs().maxCoeff() <= 0.015 && d.tail<2>().norm() > 0.004;
      }
  return mask;
}

TEST_CASE("preop segment: closing fills a tunnel narrower than the ball and stays in the convex hull", "[unit]") {
  const VoxelMask cube = PiercedCube();
  const Eigen::Vector3d centre = cube.PointOf(35, 40, 15);
  const std::size_t tunnel_middle = cube.Index(35, 40, 15);
  REQUIRE(cube.inside[tunnel_middle] == 0);
  for (const double radius_mm : {2.5, 6.0}) {
    const VoxelMask closed = ClosedSolid(cube, radius_mm);
    std::size_t lost = 0, outside_hull = 0;
    for (int k = 0; k < cube.size.z(); ++k)
      for (int j = 0; j < cube.size.y(); ++j)
        for (int i = 0; i < cube.size.x(); ++i) {
          const std::size_t v = cube.Index(i, j, k);
          lost += cube.inside[v] && !closed.inside[v];
          outside_hull += closed.inside[v] && (cube.PointOf(i, j, k) - centre).cwiseAbs().maxCoeff() > 0.015;
        }
    CHECK(lost == 0);          // a closing only adds
    CHECK(outside_hull == 0);  // and never beyond the convex hull
    // ITK's ball of 2.5 mm there reaches 3.15, 2.7, 3 mm along x, y, z and
    // passes through the tunnel of 4 mm; one of 6 mm reaches over 6 mm.
    CHECK(closed.inside[tunnel_middle] == (radius_mm > 4));
  }
}

TEST_CASE("preop segment: closing by distance maps is ITK's ball closing, on an anisotropic grid", "[unit]") {
  // Two balls joined by a thin bridge, with a dent: what a closing changes.
  VoxelMask mask;
  mask.size = Eigen::Vector3i(48, 40, 40);
  mask.spacing_m = Eigen::Vector3d(1e-3, 0.8e-3, 1.5e-3);
  mask.inside.assign(mask.num_voxels(), 0);
  for (int k = 0; k < mask.size.z(); ++k)
    for (int j = 0; j < mask.size.y(); ++j)
      for (int i = 0; i < mask.size.x(); ++i) {
        const Eigen::Vector3d p(i, j, k);
        const bool balls = (p - Eigen::Vector3d(14, 20, 20)).norm() <= 9 || (p - Eigen::Vector3d(33, 20, 20)).norm() <= 9;
        const bool bridge = std::abs(j - 20) <= 1 && std::abs(k - 20) <= 1 && i >= 14 && i <= 33;
        const bool dent = (p - Eigen::Vector3d(14, 20, 29)).norm() <= 3;
        mask.inside[mask.Index(i, j, k)] = (balls || bridge) && !dent;
      }
  constexpr double kRadius_mm = 4;  // 4, 5 and 3 voxels
  const VoxelMask closed = ClosedSolid(mask, kRadius_mm);

  using Mask = itk::Image<std::uint8_t, 3>;
  Mask::Pointer image = Mask::New();
  Mask::SizeType size;
  for (int d = 0; d < 3; ++d) size[d] = mask.size[d];
  image->SetRegions(Mask::RegionType(size));
  image->Allocate();
  std::copy(mask.inside.begin(), mask.inside.end(), image->GetBufferPointer());
  using Ball = itk::BinaryBallStructuringElement<std::uint8_t, 3>;
  Ball ball;
  Ball::SizeType radius;
  radius[0] = 4, radius[1] = 5, radius[2] = 3;
  ball.SetRadius(radius);
  ball.CreateStructuringElement();
  auto closing = itk::BinaryMorphologicalClosingImageFilter<Mask, Mask, Ball>::New();
  closing->SetInput(image);
  closing->SetKernel(ball);
  closing->SetForegroundValue(1);
  closing->SetSafeBorder(true);
  auto fill = itk::BinaryFillholeImageFilter<Mask>::New();
  fill->SetInput(closing->GetOutput());
  fill->SetForegroundValue(1);
  fill->Update();
  const std::uint8_t* itk = fill->GetOutput()->GetBufferPointer();

  std::size_t added = 0, differ = 0;
  for (std::size_t v = 0; v < mask.num_voxels(); ++v) {
    added += closed.inside[v] && !mask.inside[v];
    differ += closed.inside[v] != itk[v];
  }
  INFO("voxels the closing adds " << added << ", on " << differ << " of which ITK's differs");
  REQUIRE(added > 250);
  CHECK(differ == 0);
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

// A ball of voxels (centres within radius_vox of `centre`, voxel units) of one HU.
struct Blob {
  Eigen::Vector3d centre;
  double radius_vox;
  float hu;
};

// A CT of n^3 voxels of 1 mm, air with blobs painted in order (later over earlier).
io::CtImage BlobsCt(int n, const std::vector<Blob>& blobs, const Eigen::Matrix3d& direction = Eigen::Matrix3d::Identity()) {
  io::CtImage ct = BallCt(n, -1, direction);
  ct.source = "synthetic blobs";
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (const Blob& b : blobs)
          if ((Eigen::Vector3d(i, j, k) - b.centre).norm() <= b.radius_vox) ct.values[ct.Index(i, j, k)] = b.hu;
  return ct;
}

// The mean voxel index of a mask.
Eigen::Vector3d Centroid(const VoxelMask& mask) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  std::size_t n = 0;
  for (int k = 0; k < mask.size.z(); ++k)
    for (int j = 0; j < mask.size.y(); ++j)
      for (int i = 0; i < mask.size.x(); ++i)
        if (mask.inside[mask.Index(i, j, k)]) sum += Eigen::Vector3d(i, j, k), ++n;
  return sum / static_cast<double>(n);
}

Eigen::Matrix3d Mirror() {
  Eigen::Matrix3d mirror;
  mirror << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  return mirror;
}

// Two separate tissue balls, the larger at x = 10 voxels, the smaller at x = 24.
const Blob kLarge{{10, 16, 16}, 6, 40.0f};
const Blob kSmall{{24, 16, 16}, 4, 40.0f};

TEST_CASE("preop segment: a seed point picks its component, in any frame", "[unit]") {
  for (const Eigen::Matrix3d& direction : {Eigen::Matrix3d(Eigen::Matrix3d::Identity()), Mirror()}) {
    const io::CtImage ct = BlobsCt(32, {kLarge, kSmall}, direction);
    SegmentationOptions options;
    const Segmentation largest = Segment(ct, options);
    CHECK((Centroid(largest.organ) - kLarge.centre).norm() < 0.1);
    CHECK(largest.report.organ_components == 2);

    options.seed_point_m = ct.PointOf(kSmall.centre.x() + 2, kSmall.centre.y(), kSmall.centre.z());
    const Segmentation seeded = Segment(ct, options);
    CHECK((Centroid(seeded.organ) - kSmall.centre).norm() < 0.1);
    // Every candidate voxel outside the small ball is dropped: the large ball's.
    CHECK(seeded.report.organ_voxels_dropped == largest.report.organ_voxels);
  }
}

TEST_CASE("preop segment: a seed point in no candidate names its HU, the range and the nearest component", "[unit]") {
  const io::CtImage ct = BlobsCt(32, {kLarge, kSmall});
  SegmentationOptions options;
  options.opening_radius_mm = 0;  // the opening would take the ball's poles
  // In the air one voxel beyond the large ball's pole at (16, 16, 16): 1 mm from it.
  options.seed_point_m = ct.PointOf(17, 16, 16);
  REQUIRE_THROWS_WITH(Segment(ct, options),
                      Contains("seed point (27.0, -4.0, 46.0) mm") && Contains("-1000 HU") &&
                          Contains("[-480, 375] HU") && Contains("component (1 of 2, ") && Contains("1.0 mm away") &&
                          Contains("fix:"));
  options.seed_point_m = ct.PointOf(40, 16, 16);
  REQUIRE_THROWS_WITH(Segment(ct, options), Contains("outside the CT's grid"));
}

TEST_CASE("preop segment: automatic segmentation refuses values that are not HU", "[unit]") {
  io::CtImage ct = BlobsCt(32, {kLarge, kSmall});
  ct.values_are_hu = false;  // as read with --not-hu
  CHECK_THROWS_WITH(Segment(ct, SegmentationOptions{}), Contains("needs CT numbers in HU") && Contains("--labels"));
}

TEST_CASE("preop segment: a seed point the opening removed takes the component beside it", "[unit]") {
  const io::CtImage ct = BlobsCt(32, {kLarge, kSmall});
  SegmentationOptions options;
  options.opening_radius_mm = 2;
  options.seed_point_m = ct.PointOf(17, 16, 16);  // 1 mm beyond the large ball's pole, within the opening's 2 mm
  const Segmentation seeded = Segment(ct, options);
  CHECK((Centroid(seeded.organ) - kLarge.centre).norm() < 0.1);
  options.seed_point_m = ct.PointOf(10, 25, 16);  // 3 mm beyond its side: more than the opening and half a voxel
  CHECK_THROWS_WITH(Segment(ct, options), Contains("in no organ candidate"));
}

TEST_CASE("preop segment: voxels outside the region of interest are no candidates, in any frame", "[unit]") {
  for (const Eigen::Matrix3d& direction : {Eigen::Matrix3d(Eigen::Matrix3d::Identity()), Mirror()}) {
    const io::CtImage ct = BlobsCt(32, {kLarge, kSmall}, direction);
    SegmentationOptions options;
    // A box of S about the small ball, 6 mm each way (its corners may map to any voxel corners).
    const Eigen::Vector3d centre_m = ct.PointOf(kSmall.centre.x(), kSmall.centre.y(), kSmall.centre.z());
    options.roi_min_m = centre_m - Eigen::Vector3d::Constant(6e-3);
    options.roi_max_m = centre_m + Eigen::Vector3d::Constant(6e-3);
    const Segmentation s = Segment(ct, options);
    CHECK((Centroid(s.organ) - kSmall.centre).norm() < 0.1);
    CHECK(s.report.organ_components == 1);
    CHECK(s.report.organ_voxels_dropped == 0);

    options.roi_min_m = ct.origin_m + Eigen::Vector3d::Constant(1.0);
    options.roi_max_m = ct.origin_m + Eigen::Vector3d::Constant(1.1);
    REQUIRE_THROWS_WITH(Segment(ct, options), Contains("region of interest") && Contains("holds no voxel centre"));
  }
}

TEST_CASE("preop segment: the report gives the organ's volume, box and median HU", "[unit]") {
  // A tissue ball of radius 8 voxels with a chamber (250 HU) of radius 3 inside.
  const io::CtImage ct = BlobsCt(32, {{{16, 16, 16}, 8, 40.0f}, {{16, 16, 16}, 3, 250.0f}});
  SegmentationOptions options;
  options.opening_radius_mm = 0;  // the opening would take the ball's poles
  const Segmentation s = Segment(ct, options);
  const SegmentationReport& r = s.report;
  CHECK(r.organ_volume_ml == Approx(1e-3 * static_cast<double>(r.organ_voxels)));
  // The ball's 1 mm voxels: 4/3 pi 8^3 = 2145 mm^3 to a voxel's layer.
  CHECK(r.organ_volume_ml == Approx(4.0 / 3.0 * std::numbers::pi * 512e-3).epsilon(0.03));
  // Its voxel centres reach 8 voxels from the centre (the poles), origin (10, -20, 30) mm.
  const Eigen::Vector3d centre_mm = 1e3 * ct.PointOf(16, 16, 16);
  CHECK((r.organ_min_mm - (centre_mm - Eigen::Vector3d::Constant(8))).norm() < 1e-9);
  CHECK((r.organ_max_mm - (centre_mm + Eigen::Vector3d::Constant(8))).norm() < 1e-9);
  CHECK(r.organ_median_hu == 40.0);  // the chamber is under half the organ
  REQUIRE(s.internal.size() == 1);
  CHECK(r.internal_components == 1);
  CHECK_THAT(r.Describe(), Contains("median 40 HU") && Contains("1 internal structures kept of 1 found"));
}

TEST_CASE("preop segment: internal structures beyond the largest max_internal_structures are dropped", "[unit]") {
  // An organ ball of radius 12 with three chambers of 3.5, 3 and 2.5 voxels
  // (179, 123 and 81 voxels, over 50 mm^3) and four single-voxel specks (under it).
  std::vector<Blob> blobs = {{{16, 16, 16}, 12, 40.0f}, {{10, 16, 16}, 3.5, 250.0f}, {{22, 16, 16}, 3, 250.0f},
                             {{16, 9, 16}, 2.5, 250.0f}};
  for (const Eigen::Vector3d& speck : {Eigen::Vector3d(16, 22, 16), Eigen::Vector3d(16, 16, 10),
                                       Eigen::Vector3d(16, 16, 22), Eigen::Vector3d(13, 20, 21)}) {
    blobs.push_back({speck, 0.1, 250.0f});
  }
  const io::CtImage ct = BlobsCt(32, blobs);
  SegmentationOptions options;
  options.max_internal_structures = 2;
  const Segmentation s = Segment(ct, options);
  REQUIRE(s.internal.size() == 2);
  CHECK((Centroid(s.internal[0]) - Eigen::Vector3d(10, 16, 16)).norm() < 0.1);
  CHECK((Centroid(s.internal[1]) - Eigen::Vector3d(22, 16, 16)).norm() < 0.1);
  CHECK(s.report.internal_components == 7);
  CHECK(s.report.internal_components_dropped == 5);
  options.max_internal_structures = 0;
  CHECK(Segment(ct, options).internal.empty());
}

TEST_CASE("preop segment: the presets are valid options, and an unknown one is named", "[unit]") {
  for (const std::string& name : SegmentationPresetNames()) {
    const SegmentationOptions options = SegmentationPreset(name);
    CHECK(options.preset == name);
    CHECK(options.Validate() == "");
  }
  CHECK(SegmentationPreset("phantom").closing_radius_mm == SegmentationOptions{}.closing_radius_mm);
  CHECK_FALSE(SegmentationPreset("liver").find_mount);
  CHECK_FALSE(SegmentationPreset("lung").marker_min_hu.has_value());
  REQUIRE_THROWS_WITH(SegmentationPreset("brain"), Contains("unknown segmentation preset 'brain'") &&
                                                       Contains("cardiac-contrast") && Contains("lung"));
}

TEST_CASE("preop segment: invalid options are refused by name", "[unit]") {
  SegmentationOptions segmentation;
  segmentation.mount_hu = {600, 400};
  CHECK_THAT(segmentation.Validate(), Contains("mount_hu"));
  segmentation = {};
  segmentation.internal_labels = {1};
  CHECK_THAT(segmentation.Validate(), Contains("distinct"));
  segmentation = {};
  segmentation.roi_min_m = Eigen::Vector3d::Zero();
  CHECK_THAT(segmentation.Validate(), Contains("roi_min_m and roi_max_m"));
  segmentation.roi_max_m = Eigen::Vector3d(1, 1, 0);
  CHECK_THAT(segmentation.Validate(), Contains("roi_min_m < roi_max_m"));
  segmentation = {};
  segmentation.max_internal_structures = -1;
  CHECK_THAT(segmentation.Validate(), Contains("max_internal_structures"));
  SurfaceOptions surface;
  surface.smoothing_pass_band = 0;
  CHECK_THAT(surface.Validate(), Contains("smoothing_pass_band"));
  REQUIRE_THROWS_AS(ExtractSurface(VoxelMask::OnGridOf(BallCt(4, 1)), SurfaceOptions{}), Error);
}

}  // namespace
}  // namespace dg::stages::preop
