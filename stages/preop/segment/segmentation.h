#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
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
// filled); the mount, when there is one, is one rigid body the organ rests on.
// What is not in the organ's component is dropped, and the report counts it.
//
// Automatic mode (no label map). The defaults are preset "phantom", for the
// synthetic heart of tools/phantom/ct_synthesis.h and its 1 mm voxels
// (segmentation_presets.h has real scans' presets):
//  0. the region of interest, when given: voxels whose centres lie outside the
//     box [roi_min_m, roi_max_m] of S are no candidate for anything;
//  1. mount (find_mount): the largest connected component of mount_hu;
//  2. markers (marker_min_hu set): voxels of at least marker_min_hu, grown by
//     marker_margin_voxels to take in their partial-volume shell. The
//     fiducial beads are rigid markers glued on the surface, not tissue: the
//     paper's mesh and the phantom's true surface leave them out, and keeping
//     them would put a 2 mm bump under every bead. So they are cut out of the
//     organ and the dent they leave is closed again (step 5);
//  3. the organ's candidates: organ_hu (tissue and internal structures) minus
//     the mount and the markers, opened by a ball of opening_radius_mm: on the
//     phantom (one voxel) this removes the layer of mount-air partial volume
//     on top of the mount, whose mixed values fall in the tissue range; on a
//     patient it cuts the thin bridges between touching organs;
//  4. the organ is the candidates' connected component (face-connected) that
//     holds seed_point_m, or without a seed point the largest one;
//  5. closed by a ball of closing_radius_mm (restores the markers' dents, a
//     bead's radius plus the margin deep: a ball wider than the dent cannot
//     enter it; on the phantom 5 mm left 1.6 mm at worst, 3 mm left 2.4 mm)
//     and holes filled;
//  6. internal structures: internal_hu inside the organ eroded by one voxel
//     (the organ's bottom layer mixes tissue with mount into the internal
//     range) and away from the markers, split into structures; those of at
//     least min_internal_volume_m3 are kept, largest first, at most
//     max_internal_structures of them, and the others are counted as dropped.
//     Structures that touch (the phantom's two chambers share a contact patch
//     about 5 voxels across) are one connected component, and an opening
//     would need a ball wider than the patch; they are told apart by the
//     watershed of the distance to the mask's boundary, whose basins are the
//     blobs, minima less than internal_split_depth_voxels deep merged.
// Ball radii given in mm become a number of voxels along each axis (rounded),
// so a ball on anisotropic voxels is an ellipsoid of voxels.
//
// Memory: components are one label image (32 bits a voxel), never a mask per
// component; the internal structures are split within their bounding box,
// and only the structures kept become VoxelMasks. The peak stays under 6
// times the CT's own size (a test).
//
// Label-map mode: organ = organ_label or any internal label, then steps 4-5
// (largest component, holes filled; no closing; no region of interest or
// seed point); mount = mount_label; each internal label is one structure.
struct SegmentationOptions {
  // The preset these options came from (SegmentationPreset), for the report.
  std::string preset = "phantom";

  // Automatic mode. Bounds sit half-way between the phantom's materials.
  HuRange organ_hu{-480, 375};
  HuRange internal_hu{145, 375};
  HuRange mount_hu{375, 1750};
  bool find_mount = true;                       // false: no mount (a patient)
  std::optional<double> marker_min_hu = 1750;   // empty: no markers cut out
  int marker_margin_voxels = 1;
  double opening_radius_mm = 1.0;               // 0: no opening
  double closing_radius_mm = 5.0;               // 0: no closing
  double internal_split_depth_voxels = 1.0;
  double min_internal_volume_m3 = 50e-9;        // 50 mm^3
  int max_internal_structures = 8;              // 0: no internal structures

  // Automatic mode: a box of S (metres) outside which no voxel is a
  // candidate; both corners or neither.
  std::optional<Eigen::Vector3d> roi_min_m;
  std::optional<Eigen::Vector3d> roi_max_m;
  // Automatic mode: a point of S (metres) inside the organ; its candidate
  // component is the organ instead of the largest one.
  std::optional<Eigen::Vector3d> seed_point_m;

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
  std::size_t organ_voxels_dropped = 0;     // candidates outside the organ's component
  int organ_components = 0;                 // candidate components, the organ's among them
  int internal_components = 0;              // internal components found (touching ones split)
  int internal_components_dropped = 0;      // under min_internal_volume_m3 or beyond max_internal_structures

  // What was segmented: the organ's volume, the bounding box of its voxels'
  // centres in S, and the median CT number inside it.
  double organ_volume_ml = 0;
  Eigen::Vector3d organ_min_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d organ_max_mm = Eigen::Vector3d::Zero();
  double organ_median_hu = 0;

  std::string Describe() const;  // one line: volume, box, median HU, components found and dropped
};

struct Segmentation {
  VoxelMask organ;                  // the solid, internal structures included
  VoxelMask mount;                  // empty (all zero) when there is none
  std::vector<VoxelMask> internal;  // largest first (automatic) or in label order
  SegmentationReport report;
};

// Automatic segmentation of one CT phase, on any direction of its grid.
// @throws dg::Error for invalid options, an image whose values are not HU
//   (io::CtImage::values_are_hu), an image without voxels, a region of
//   interest that misses the grid, when no organ voxel is found (naming the
//   HU range and the image's own range), and a seed point outside the grid or
//   the region or in no candidate component (naming the point, its voxel's HU,
//   the range and the nearest candidate component).
Segmentation Segment(const io::CtImage& ct, const SegmentationOptions& options);

// The mask closed by a ball of radius_mm (in voxels along each axis,
// rounded) and its holes filled: what closes a tunnel through the solid
// narrower than the ball, such as a vessel through the liver, which the
// mesher's solid of spherical topology cannot have.
VoxelMask ClosedSolid(const VoxelMask& mask, double radius_mm);

// Segmentation from a label map on the CT's grid (3D Slicer, ITK-SNAP).
// @throws dg::Error for invalid options, a label map on another grid (size,
//   spacing, origin or direction), a label (organ, mount or internal) that
//   no voxel carries.
Segmentation Segment(const io::CtImage& ct, const io::CtImage& labels, const SegmentationOptions& options);

}  // namespace dg::stages::preop
