#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/ct/ct_image.h"

namespace dg::stages::preop {

// A binary mask on a CT's voxel grid: the grid's geometry as in io::CtImage
// (voxel (i, j, k) centred at origin_m + direction * (spacing_m .* (i, j, k)))
// and one byte per voxel, x fastest, 1 inside and 0 outside.
struct VoxelMask {
  Eigen::Vector3i size = Eigen::Vector3i::Zero();
  Eigen::Vector3d spacing_m = Eigen::Vector3d::Constant(1e-3);
  Eigen::Vector3d origin_m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();
  std::vector<std::uint8_t> inside;

  // An empty mask (all zero) on the grid of `image`.
  static VoxelMask OnGridOf(const io::CtImage& image);

  std::size_t num_voxels() const { return static_cast<std::size_t>(size.x()) * size.y() * size.z(); }
  std::size_t Index(int i, int j, int k) const {
    return static_cast<std::size_t>(i) + size.x() * (static_cast<std::size_t>(j) + static_cast<std::size_t>(size.y()) * k);
  }
  std::size_t Count() const;  // voxels inside
  double Volume_m3() const { return static_cast<double>(Count()) * spacing_m.prod(); }
  Eigen::Vector3d PointOf(double i, double j, double k) const {
    return origin_m + direction * spacing_m.cwiseProduct(Eigen::Vector3d(i, j, k));
  }
};

// An inclusive range of CT numbers, HU.
struct HuRange {
  double min_hu = 0;
  double max_hu = 0;
  bool Contains(double hu) const { return hu >= min_hu && hu <= max_hu; }
};

// Segmentation of one CT phase into the solid to simulate, its static support
// and its internal structures (the first step of the paper's section 2.4).
//
// Assumptions, as the paper's: the organ is ONE solid of spherical topology
// (one connected component, no tunnels; the internal structures lie inside it
// and are part of the solid, so the solid is the organ with its cavities
// filled); the mount is one rigid body the organ rests on. What is not in the
// organ's largest connected component is dropped, and the report counts it.
//
// Automatic mode (no label map), on the phantom's CT numbers in HU (air at -1000,
// epicardial fat at -100, tissue at 40, chambers 250, mount 500, beads 3000):
//  1. mount: the largest connected component of mount_hu;
//  2. markers: voxels of at least marker_min_hu, grown by marker_margin_voxels
//     to take in their partial-volume shell. The fiducial beads are rigid
//     markers glued on the surface, not tissue: the paper's mesh and the
//     phantom's true surface leave them out, and keeping them would put a
//     2 mm bump under every bead. So they are cut out of the organ and the
//     dent they leave is closed again (step 5);
//  3. the organ's candidates: organ_hu (tissue and internal structures) minus
//     the mount and the markers, opened by one voxel (a ball of radius 1):
//     this removes the one-voxel layer of mount-air partial volume on top of
//     the mount, whose mixed values fall in the tissue range;
//  4. the largest connected component (face-connected);
//  5. closed by a ball of closing_radius_voxels (restores the markers' dents,
//     a bead's radius plus the margin deep: a ball wider than the dent cannot
//     enter it; on the phantom 5 voxels left 1.6 mm at worst, 3 left 2.4 mm)
//     and holes filled;
//  6. internal structures: internal_hu inside the organ eroded by one voxel
//     (the organ's bottom layer mixes tissue with mount into the internal
//     range) and away from the markers, split into structures, largest
//     first, those under min_internal_volume_m3 dropped and counted. Structures
//     that touch (the phantom's two chambers share a contact patch about 5
//     voxels across) are one connected component, and an opening would need
//     a ball wider than the patch; they are told apart by the watershed of the
//     distance to the mask's boundary, whose basins are the blobs, minima
//     less than internal_split_depth_voxels deep merged.
//
// Label-map mode: organ = organ_label or any internal label, then steps 4-5
// (largest component, holes filled; no closing); mount = mount_label; each
// internal label is one structure.
struct SegmentationOptions {
  // Automatic mode. Bounds sit half-way between the phantom's materials.
  HuRange organ_hu{-480, 375};
  HuRange internal_hu{145, 375};
  HuRange mount_hu{375, 1750};
  double marker_min_hu = 1750;
  int marker_margin_voxels = 1;
  int closing_radius_voxels = 5;
  double internal_split_depth_voxels = 1.0;
  double min_internal_volume_m3 = 50e-9;  // 50 mm^3

  // Label-map mode (used when Segment() is given a label map).
  int organ_label = 1;
  int mount_label = 2;                 // 0: no mount
  std::vector<int> internal_labels;    // each one structure

  std::string Validate() const;  // empty when valid, else what is wrong
};

// What the segmentation kept and dropped, for the command's report.
struct SegmentationReport {
  std::size_t organ_voxels = 0;
  std::size_t mount_voxels = 0;
  std::vector<std::size_t> internal_voxels;
  std::size_t organ_voxels_dropped = 0;     // candidates outside the largest component
  int internal_components_dropped = 0;      // components under min_internal_volume_m3
};

struct Segmentation {
  VoxelMask organ;                  // the solid, internal structures included
  VoxelMask mount;                  // empty (all zero) when there is none
  std::vector<VoxelMask> internal;  // largest first (automatic) or in label order
  SegmentationReport report;
};

// Automatic segmentation of one CT phase.
// @throws dg::Error for invalid options, an image without voxels, or when no
//   organ voxel is found (naming the HU range and the image's own range).
Segmentation Segment(const io::CtImage& ct, const SegmentationOptions& options);

// Segmentation from a label map on the CT's grid (3D Slicer, ITK-SNAP).
// @throws dg::Error for invalid options, a label map on another grid (size,
//   spacing, origin or direction), a label (organ, mount or internal) that
//   no voxel carries.
Segmentation Segment(const io::CtImage& ct, const io::CtImage& labels, const SegmentationOptions& options);

}  // namespace dg::stages::preop
