#include "stages/preop/segment/segmentation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <vector>

// The system's Eigen modules before ITK's headers: ITK's bundled Eigen (3.3,
// same include guards) then uses them instead of compiling its own against ours.
#include <Eigen/Dense>
#include <fmt/format.h>
#include <itkBinaryBallStructuringElement.h>
#include <itkBinaryDilateImageFilter.h>
#include <itkBinaryErodeImageFilter.h>
#include <itkBinaryFillholeImageFilter.h>
#include <itkBinaryMorphologicalClosingImageFilter.h>
#include <itkBinaryMorphologicalOpeningImageFilter.h>
#include <itkBinaryThresholdImageFilter.h>
#include <itkConnectedComponentImageFilter.h>
#include <itkImage.h>
#include <itkMorphologicalWatershedImageFilter.h>
#include <itkRelabelComponentImageFilter.h>
#include <itkScalarConnectedComponentImageFilter.h>
#include <itkSignedMaurerDistanceMapImageFilter.h>

#include "sim/error.h"
#include "sim/log.h"

namespace dg::stages::preop {
namespace {

using MaskImage = itk::Image<std::uint8_t, 3>;
using HuImage = itk::Image<float, 3>;
using LabelImage = itk::Image<std::uint32_t, 3>;
using Ball = itk::BinaryBallStructuringElement<std::uint8_t, 3>;

// A box of voxels of a grid: the first voxel and the extent, x fastest.
struct Box {
  Eigen::Vector3i start = Eigen::Vector3i::Zero();
  Eigen::Vector3i size = Eigen::Vector3i::Zero();
  std::size_t num_voxels() const { return static_cast<std::size_t>(size.x()) * size.y() * size.z(); }
  std::size_t Index(const Eigen::Vector3i& local) const {
    return static_cast<std::size_t>(local.x()) +
           size.x() * (static_cast<std::size_t>(local.y()) + static_cast<std::size_t>(size.y()) * local.z());
  }
  bool Contains(const Eigen::Vector3i& v) const {
    return (v.array() >= start.array()).all() && (v.array() < (start + size).array()).all();
  }
};

// Calls f(index in the box, index in the grid of `grid_size`) for each voxel of the box.
template <class F>
void ForEachVoxel(const Box& box, const Eigen::Vector3i& grid_size, F&& f) {
  std::size_t local = 0;
  for (int k = 0; k < box.size.z(); ++k) {
    for (int j = 0; j < box.size.y(); ++j) {
      std::size_t global = static_cast<std::size_t>(box.start.x()) +
                           grid_size.x() * (static_cast<std::size_t>(box.start.y() + j) +
                                            static_cast<std::size_t>(grid_size.y()) * (box.start.z() + k));
      for (int i = 0; i < box.size.x(); ++i) f(local++, global++);
    }
  }
}

// The filters work in voxel units (radii in voxels, components by face
// adjacency), so the images carry the box's size only; geometry stays in the
// VoxelMask.
template <class Image>
typename Image::Pointer NewImage(const Eigen::Vector3i& size, bool zero = false) {
  typename Image::Pointer image = Image::New();
  typename Image::SizeType itk_size;
  for (int d = 0; d < 3; ++d) itk_size[d] = static_cast<itk::SizeValueType>(size[d]);
  image->SetRegions(typename Image::RegionType(itk_size));
  image->Allocate(zero);
  return image;
}

template <class Image>
std::size_t NumPixels(const Image* image) {
  return image->GetBufferedRegion().GetNumberOfPixels();
}

// The CT's voxels in `box` as an ITK image: the CT's own buffer when the box
// is the whole grid (no copy; the filters only read it), else a copy in which
// voxels whose centres lie outside the region of interest are -infinity, in
// no HU range.
HuImage::Pointer WorkingImage(const io::CtImage& ct, const Box& box, const SegmentationOptions& options) {
  HuImage::Pointer image = HuImage::New();
  typename HuImage::SizeType itk_size;
  for (int d = 0; d < 3; ++d) itk_size[d] = static_cast<itk::SizeValueType>(box.size[d]);
  image->SetRegions(HuImage::RegionType(itk_size));
  if (!options.roi_min_m) {
    image->GetPixelContainer()->SetImportPointer(const_cast<float*>(ct.values.data()), ct.values.size(),
                                                 /*LetContainerManageMemory=*/false);
    return image;
  }
  image->Allocate();
  float* out = image->GetBufferPointer();
  const Eigen::Vector3d lo = *options.roi_min_m, hi = *options.roi_max_m;
  const Eigen::Vector3d margin = Eigen::Vector3d::Constant(1e-9);
  std::size_t local = 0;
  for (int k = 0; k < box.size.z(); ++k)
    for (int j = 0; j < box.size.y(); ++j)
      for (int i = 0; i < box.size.x(); ++i, ++local) {
        const Eigen::Vector3i v = box.start + Eigen::Vector3i(i, j, k);
        const Eigen::Vector3d x = ct.PointOf(v.x(), v.y(), v.z());
        const bool inside = ((x - lo).array() >= -margin.array()).all() && ((hi - x).array() >= -margin.array()).all();
        out[local] = inside ? ct.at(v.x(), v.y(), v.z()) : -std::numeric_limits<float>::infinity();
      }
  return image;
}

// Runs a filter on `input` and detaches its output from the pipeline.
template <class Filter>
typename Filter::OutputImageType::Pointer Run(Filter* filter, const typename Filter::InputImageType* input) {
  filter->SetInput(input);
  filter->Update();
  typename Filter::OutputImageType::Pointer output = filter->GetOutput();
  output->DisconnectPipeline();
  return output;
}

MaskImage::Pointer Threshold(const HuImage* ct, const HuRange& range) {
  auto filter = itk::BinaryThresholdImageFilter<HuImage, MaskImage>::New();
  filter->SetLowerThreshold(static_cast<float>(range.min_hu));
  filter->SetUpperThreshold(static_cast<float>(std::min<double>(range.max_hu, std::numeric_limits<float>::max())));
  filter->SetInsideValue(1);
  filter->SetOutsideValue(0);
  return Run(filter.GetPointer(), ct);
}

// A ball of radius_mm on voxels of spacing_m: a number of voxels along each
// axis, rounded (an ellipsoid of voxels on anisotropic grids).
Eigen::Vector3i RadiusVoxels(double radius_mm, const Eigen::Vector3d& spacing_m) {
  return (radius_mm / (1e3 * spacing_m.array())).round().cast<int>();
}

Ball BallOfRadius(const Eigen::Vector3i& radius_voxels) {
  Ball ball;
  Ball::SizeType radius;
  for (int d = 0; d < 3; ++d) radius[d] = static_cast<itk::SizeValueType>(radius_voxels[d]);
  ball.SetRadius(radius);
  ball.CreateStructuringElement();
  return ball;
}

MaskImage::Pointer Dilate(MaskImage::Pointer mask, const Eigen::Vector3i& radius_voxels) {
  if (radius_voxels.maxCoeff() == 0) return mask;
  auto filter = itk::BinaryDilateImageFilter<MaskImage, MaskImage, Ball>::New();
  filter->SetKernel(BallOfRadius(radius_voxels));
  filter->SetForegroundValue(1);
  filter->SetBackgroundValue(0);
  return Run(filter.GetPointer(), mask.GetPointer());
}

MaskImage::Pointer Erode(const MaskImage* mask, int radius_voxels) {
  auto filter = itk::BinaryErodeImageFilter<MaskImage, MaskImage, Ball>::New();
  filter->SetKernel(BallOfRadius(Eigen::Vector3i::Constant(radius_voxels)));
  filter->SetForegroundValue(1);
  filter->SetBackgroundValue(0);
  filter->SetBoundaryToForeground(false);  // what touches the grid's edge is not interior
  return Run(filter.GetPointer(), mask);
}

MaskImage::Pointer Open(MaskImage::Pointer mask, const Eigen::Vector3i& radius_voxels) {
  if (radius_voxels.maxCoeff() == 0) return mask;
  auto filter = itk::BinaryMorphologicalOpeningImageFilter<MaskImage, MaskImage, Ball>::New();
  filter->SetKernel(BallOfRadius(radius_voxels));
  filter->SetForegroundValue(1);
  filter->SetBackgroundValue(0);
  return Run(filter.GetPointer(), mask.GetPointer());
}

MaskImage::Pointer Close(MaskImage::Pointer mask, const Eigen::Vector3i& radius_voxels) {
  if (radius_voxels.maxCoeff() == 0) return mask;
  auto filter = itk::BinaryMorphologicalClosingImageFilter<MaskImage, MaskImage, Ball>::New();
  filter->SetKernel(BallOfRadius(radius_voxels));
  filter->SetForegroundValue(1);
  filter->SetSafeBorder(true);  // nothing grows in from beyond the grid
  return Run(filter.GetPointer(), mask.GetPointer());
}

MaskImage::Pointer FillHoles(const MaskImage* mask) {
  auto filter = itk::BinaryFillholeImageFilter<MaskImage>::New();
  filter->SetForegroundValue(1);
  filter->SetFullyConnected(false);
  return Run(filter.GetPointer(), mask);
}

std::size_t CountInside(const MaskImage* mask) {
  const std::uint8_t* v = mask->GetBufferPointer();
  return static_cast<std::size_t>(std::count(v, v + NumPixels(mask), 1));
}

// keep & ~remove, voxel by voxel, in place.
void Subtract(MaskImage* keep, const MaskImage* remove) {
  std::uint8_t* k = keep->GetBufferPointer();
  const std::uint8_t* r = remove->GetBufferPointer();
  for (std::size_t i = 0, n = NumPixels(keep); i < n; ++i) k[i] &= !r[i];
}

// keep & within, voxel by voxel, in place.
void Intersect(MaskImage* keep, const MaskImage* within) {
  std::uint8_t* k = keep->GetBufferPointer();
  const std::uint8_t* w = within->GetBufferPointer();
  for (std::size_t i = 0, n = NumPixels(keep); i < n; ++i) k[i] &= w[i];
}

// Connected components as one label image: 1 the largest, then by size; 0
// the background and components under the minimum size (dropped).
struct Components {
  LabelImage::Pointer labels;
  std::vector<std::size_t> sizes;  // sizes[l - 1]: voxels of label l
  int found = 0;                   // components before the minimum size
};

// Sorts and renumbers the labels of `labels` (in place) by size.
Components Relabel(LabelImage::Pointer labels, std::size_t min_voxels) {
  auto relabel = itk::RelabelComponentImageFilter<LabelImage, LabelImage>::New();
  relabel->SetSortByObjectSize(true);
  relabel->SetMinimumObjectSize(min_voxels);
  relabel->SetInPlace(true);  // one label image, not two
  Components c;
  c.labels = Run(relabel.GetPointer(), labels.GetPointer());
  for (auto size : relabel->GetSizeOfObjectsInPixels()) c.sizes.push_back(static_cast<std::size_t>(size));
  c.found = static_cast<int>(relabel->GetOriginalNumberOfObjects());
  return c;
}

// The face-connected components of a mask.
Components LabelComponents(const MaskImage* mask, std::size_t min_voxels = 0) {
  auto label = itk::ConnectedComponentImageFilter<MaskImage, LabelImage>::New();
  label->SetFullyConnected(false);
  return Relabel(Run(label.GetPointer(), mask), min_voxels);
}

template <class Image>
Eigen::Vector3i SizeOf(const Image* image) {
  const auto size = image->GetBufferedRegion().GetSize();
  return {static_cast<int>(size[0]), static_cast<int>(size[1]), static_cast<int>(size[2])};
}

// One component of a label image as a mask.
MaskImage::Pointer Pick(const LabelImage* labels, std::uint32_t label) {
  MaskImage::Pointer mask = NewImage<MaskImage>(SizeOf(labels));
  const std::uint32_t* in = labels->GetBufferPointer();
  std::uint8_t* out = mask->GetBufferPointer();
  for (std::size_t v = 0, n = NumPixels(labels); v < n; ++v) out[v] = in[v] == label;
  return mask;
}

// The smallest box of `mask`'s voxels holding every voxel inside, grown by
// `pad` voxels within the mask's grid; empty when no voxel is inside.
Box BoundingBox(const MaskImage* mask, int pad) {
  const Eigen::Vector3i size = SizeOf(mask);
  Eigen::Vector3i lo = size, hi = Eigen::Vector3i::Constant(-1);
  const std::uint8_t* v = mask->GetBufferPointer();
  std::size_t n = 0;
  for (int k = 0; k < size.z(); ++k)
    for (int j = 0; j < size.y(); ++j)
      for (int i = 0; i < size.x(); ++i)
        if (v[n++]) {
          lo = lo.cwiseMin(Eigen::Vector3i(i, j, k));
          hi = hi.cwiseMax(Eigen::Vector3i(i, j, k));
        }
  if (hi.x() < 0) return {};
  lo = (lo.array() - pad).max(0);
  hi = (hi.array() + pad).min(size.array() - 1);
  return {lo, hi - lo + Eigen::Vector3i::Ones()};
}

template <class Image>
typename Image::Pointer Crop(const Image* image, const Box& box) {
  typename Image::Pointer out = NewImage<Image>(box.size);
  const auto* in = image->GetBufferPointer();
  auto* o = out->GetBufferPointer();
  ForEachVoxel(box, SizeOf(image), [&](std::size_t local, std::size_t global) { o[local] = in[global]; });
  return out;
}

// The internal structures of `mask`, with structures that touch told apart:
// the watershed of the distance to the mask's boundary (each basin one
// blob's centre; a neck between two blobs is a ridge of the negated
// distance). Minima shallower than depth_voxels are merged, so a voxelised
// boundary's bumps do not split one blob. Each basin is cut back to the mask,
// and its connected pieces are the structures, labelled by size within
// `box` (the mask's bounding box), those under min_voxels dropped.
Components SplitTouching(const MaskImage* mask, double depth_voxels, std::size_t min_voxels, Box* box) {
  *box = BoundingBox(mask, 1);
  if (box->num_voxels() == 0) return {};
  const MaskImage::Pointer cropped = Crop(mask, *box);
  auto distance = itk::SignedMaurerDistanceMapImageFilter<MaskImage, HuImage>::New();
  distance->SetInsideIsPositive(false);  // negative inside: the blobs' centres are minima
  distance->SetSquaredDistance(false);
  distance->SetUseImageSpacing(false);
  distance->SetBackgroundValue(0);
  auto watershed = itk::MorphologicalWatershedImageFilter<HuImage, LabelImage>::New();
  watershed->SetLevel(static_cast<float>(depth_voxels));
  watershed->SetMarkWatershedLine(false);
  watershed->SetFullyConnected(false);
  const LabelImage::Pointer basins =
      Run(watershed.GetPointer(), Run(distance.GetPointer(), cropped.GetPointer()).GetPointer());
  // Voxels of one basin and of the mask that touch: the same label, outside
  // the mask background.
  auto pieces = itk::ScalarConnectedComponentImageFilter<LabelImage, LabelImage, MaskImage>::New();
  pieces->SetDistanceThreshold(0);
  pieces->SetFullyConnected(false);
  pieces->SetMaskImage(cropped);
  return Relabel(Run(pieces.GetPointer(), basins.GetPointer()), min_voxels);
}

VoxelMask MaskOnGrid(const io::CtImage& ct, const Box& box, const MaskImage* image) {
  VoxelMask mask = VoxelMask::OnGridOf(ct);
  if (!image) return mask;
  const std::uint8_t* in = image->GetBufferPointer();
  ForEachVoxel(box, ct.size, [&](std::size_t local, std::size_t global) { mask.inside[global] = in[local]; });
  return mask;
}

VoxelMask LabelOnGrid(const io::CtImage& ct, const Box& box, const LabelImage* labels, std::uint32_t label) {
  VoxelMask mask = VoxelMask::OnGridOf(ct);
  const std::uint32_t* in = labels->GetBufferPointer();
  ForEachVoxel(box, ct.size, [&](std::size_t local, std::size_t global) { mask.inside[global] = in[local] == label; });
  return mask;
}

// The box of voxels whose centres may lie in the region of interest (the
// whole grid without one): the box of S mapped to continuous voxel indices,
// its corners' bounds; on an oblique grid, WorkingImage excludes the corners
// outside the box of S.
Box WorkingBox(const io::CtImage& ct, const SegmentationOptions& options) {
  Box all{Eigen::Vector3i::Zero(), ct.size};
  if (!options.roi_min_m) return all;
  const Eigen::Matrix3d to_index = (ct.direction * ct.spacing_m.asDiagonal()).inverse();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(HUGE_VAL), hi = -lo;
  for (int corner = 0; corner < 8; ++corner) {
    Eigen::Vector3d x;
    for (int d = 0; d < 3; ++d) x[d] = (corner >> d & 1) ? (*options.roi_max_m)[d] : (*options.roi_min_m)[d];
    const Eigen::Vector3d index = to_index * (x - ct.origin_m);
    lo = lo.cwiseMin(index);
    hi = hi.cwiseMax(index);
  }
  const Eigen::Vector3i first = (lo.array() - 1e-6).ceil().max(0).cast<int>();
  const Eigen::Vector3i last =
      (hi.array() + 1e-6).floor().min((ct.size.array() - 1).cast<double>()).cast<int>();
  if ((last.array() < first.array()).any()) {
    const Eigen::Vector3d far = ct.PointOf(ct.size.x() - 1, ct.size.y() - 1, ct.size.z() - 1);
    throw Error(fmt::format("the region of interest [{:.1f}, {:.1f}, {:.1f}] .. [{:.1f}, {:.1f}, {:.1f}] mm holds no "
                            "voxel centre of the CT, whose voxels run from ({:.1f}, {:.1f}, {:.1f}) to ({:.1f}, "
                            "{:.1f}, {:.1f}) mm",
                            1e3 * options.roi_min_m->x(), 1e3 * options.roi_min_m->y(), 1e3 * options.roi_min_m->z(),
                            1e3 * options.roi_max_m->x(), 1e3 * options.roi_max_m->y(), 1e3 * options.roi_max_m->z(),
                            1e3 * ct.origin_m.x(), 1e3 * ct.origin_m.y(), 1e3 * ct.origin_m.z(), 1e3 * far.x(),
                            1e3 * far.y(), 1e3 * far.z()),
                ct.source, "give the region of interest in the scan frame S (LPS for DICOM), in mm");
  }
  return {first, last - first + Eigen::Vector3i::Ones()};
}

std::string Millimetres(const Eigen::Vector3d& v_m) {
  return fmt::format("({:.1f}, {:.1f}, {:.1f}) mm", 1e3 * v_m.x(), 1e3 * v_m.y(), 1e3 * v_m.z());
}

std::string RangeText(const HuRange& range) { return fmt::format("[{:g}, {:g}] HU", range.min_hu, range.max_hu); }

// The voxel nearest to a point of S, which may lie outside the grid.
Eigen::Vector3i VoxelOf(const io::CtImage& ct, const Eigen::Vector3d& x_m) {
  const Eigen::Vector3d index = (ct.direction * ct.spacing_m.asDiagonal()).inverse() * (x_m - ct.origin_m);
  return index.array().round().cast<int>();
}

// The label of the candidate component that holds the seed point, or the
// nearest one when the point's voxel was removed by the opening (within its
// radius and half a voxel).
// @throws dg::Error when the point lies outside the grid or the region, or
//   farther from every candidate component, naming the nearest one.
std::uint32_t SeedLabel(const io::CtImage& ct, const Box& box, const Components& candidates,
                        const SegmentationOptions& options) {
  const Eigen::Vector3d seed_m = *options.seed_point_m;
  const Eigen::Vector3i v = VoxelOf(ct, seed_m);
  const std::string fix = "give a seed point inside the organ, in the scan frame S (LPS for DICOM), in mm, or "
                          "widen the organ's HU range";
  if (!Box{Eigen::Vector3i::Zero(), ct.size}.Contains(v) || !box.Contains(v)) {
    throw Error(fmt::format("the seed point {} lies outside the CT's grid{} (nearest voxel index ({}, {}, {}) of {} x "
                            "{} x {})",
                            Millimetres(seed_m), options.roi_min_m ? " or the region of interest" : "", v.x(), v.y(),
                            v.z(), ct.size.x(), ct.size.y(), ct.size.z()),
                ct.source, fix);
  }
  const Eigen::Vector3i local = v - box.start;
  const std::uint32_t* labels = candidates.labels->GetBufferPointer();
  if (const std::uint32_t label = labels[box.Index(local)]; label != 0) return label;

  // The nearest voxel of any candidate component, for the message.
  const Eigen::Matrix3d to_s = ct.direction * ct.spacing_m.asDiagonal();
  double best_m = HUGE_VAL;
  Eigen::Vector3i best_voxel = Eigen::Vector3i::Zero();
  std::uint32_t best_label = 0;
  std::size_t n = 0;
  for (int k = 0; k < box.size.z(); ++k)
    for (int j = 0; j < box.size.y(); ++j)
      for (int i = 0; i < box.size.x(); ++i, ++n) {
        if (labels[n] == 0) continue;
        const double d_m = (to_s * (Eigen::Vector3i(i, j, k) - local).cast<double>()).norm();
        if (d_m < best_m) {
          best_m = d_m;
          best_voxel = box.start + Eigen::Vector3i(i, j, k);
          best_label = labels[n];
        }
      }
  // The opening removes voxels up to its radius from what it keeps: a seed in
  // such a voxel (an organ's thin rim, a vessel's wall) means the component
  // the opening left beside it.
  const double reach_m = 1e-3 * options.opening_radius_mm + 0.5 * ct.spacing_m.maxCoeff();
  if (best_label != 0 && best_m <= reach_m) {
    Logger("stages").info("the seed point {} is in no organ candidate; taking the nearest candidate component, "
                          "{:.1f} mm away (within the opening's {:g} mm)",
                          Millimetres(seed_m), 1e3 * best_m, options.opening_radius_mm);
    return best_label;
  }
  const double voxel_ml = 1e6 * ct.spacing_m.prod();
  std::string nearest = best_label == 0
                            ? "no candidate component at all"
                            : fmt::format("the nearest candidate component ({} of {}, {:.1f} ml) reaches {}, {:.1f} mm "
                                          "away",
                                          best_label, candidates.sizes.size(),
                                          voxel_ml * static_cast<double>(candidates.sizes[best_label - 1]),
                                          Millimetres(ct.PointOf(best_voxel.x(), best_voxel.y(), best_voxel.z())),
                                          1e3 * best_m);
  const float hu = ct.at(v.x(), v.y(), v.z());
  throw Error(fmt::format("the seed point {} is in no organ candidate: its voxel ({}, {}, {}) holds {:g} HU, the organ "
                          "range is {}{}; {}",
                          Millimetres(seed_m), v.x(), v.y(), v.z(), hu, RangeText(options.organ_hu),
                          options.organ_hu.Contains(hu)
                              ? fmt::format(" (in range, but removed with the mount, the markers or the opening "
                                            "by {:g} mm)",
                                            options.opening_radius_mm)
                              : "",
                          nearest),
              ct.source, fix);
}

std::string ValidateRange(const HuRange& range, const char* name) {
  if (!std::isfinite(range.min_hu) || !std::isfinite(range.max_hu) || range.min_hu > range.max_hu) {
    return fmt::format("{} must be a finite range with min_hu <= max_hu, got {}", name, RangeText(range));
  }
  return "";
}

void RequireValid(const SegmentationOptions& options, const io::CtImage& ct) {
  if (std::string problem = options.Validate(); !problem.empty()) {
    throw Error("invalid segmentation options: " + problem, ct.source, "correct the option");
  }
  if (ct.num_voxels() == 0 || ct.values.size() != ct.num_voxels()) {
    throw Error(fmt::format("CT image of {} x {} x {} voxels holds {} values", ct.size.x(), ct.size.y(),
                            ct.size.z(), ct.values.size()),
                ct.source, "give a non-empty CT phase");
  }
}

// The report's counts and its description of the organ: volume, bounding box
// of its voxels' centres in S, median HU.
void Summarise(const io::CtImage& ct, Segmentation* s) {
  SegmentationReport& r = s->report;
  r.organ_voxels = s->organ.Count();
  r.mount_voxels = s->mount.Count();
  r.internal_voxels.clear();
  for (const VoxelMask& m : s->internal) r.internal_voxels.push_back(m.Count());
  r.organ_volume_ml = 1e6 * s->organ.Volume_m3();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(HUGE_VAL), hi = -lo;
  std::vector<float> hu;
  hu.reserve(r.organ_voxels);
  std::size_t n = 0;
  for (int k = 0; k < ct.size.z(); ++k)
    for (int j = 0; j < ct.size.y(); ++j)
      for (int i = 0; i < ct.size.x(); ++i, ++n) {
        if (!s->organ.inside[n]) continue;
        const Eigen::Vector3d x = ct.PointOf(i, j, k);
        lo = lo.cwiseMin(x);
        hi = hi.cwiseMax(x);
        hu.push_back(ct.values[n]);
      }
  if (hu.empty()) return;
  r.organ_min_mm = 1e3 * lo;
  r.organ_max_mm = 1e3 * hi;
  auto middle = hu.begin() + static_cast<std::ptrdiff_t>(hu.size() / 2);
  std::nth_element(hu.begin(), middle, hu.end());
  r.organ_median_hu = *middle;
}

void LogSegmentation(const Segmentation& s, const std::string& source) {
  Logger("stages").info("segmented {}: {}", source, s.report.Describe());
}

// Runs the ITK part of a segmentation, turning ITK's exceptions into dg::Error.
template <class F>
Segmentation Guarded(const io::CtImage& ct, F&& segment) {
  try {
    return segment();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("segmentation failed in ITK: ") + e.GetDescription(), ct.source,
                "check the CT image and the segmentation options");
  }
}

// Steps 1-5 of the automatic mode within `box`: the organ's solid, and the
// mount and markers (null when there are none) for step 6.
struct Solids {
  MaskImage::Pointer organ, mount, markers;
};

Solids SegmentSolids(const io::CtImage& ct, const Box& box, const HuImage* hu, const SegmentationOptions& options,
                     SegmentationReport* report) {
  Solids s;
  if (options.find_mount) {
    const Components mounts = LabelComponents(Threshold(hu, options.mount_hu));
    if (!mounts.sizes.empty()) s.mount = Pick(mounts.labels, 1);
  }
  if (options.marker_min_hu) {
    s.markers = Dilate(Threshold(hu, {*options.marker_min_hu, HUGE_VAL}),
                       Eigen::Vector3i::Constant(options.marker_margin_voxels));
  }
  MaskImage::Pointer candidates = Threshold(hu, options.organ_hu);
  if (s.mount) Subtract(candidates, s.mount);
  if (s.markers) Subtract(candidates, s.markers);
  candidates = Open(candidates, RadiusVoxels(options.opening_radius_mm, ct.spacing_m));
  const std::size_t candidate_voxels = CountInside(candidates);
  const Components components = LabelComponents(candidates);
  candidates = nullptr;
  if (components.sizes.empty()) {
    const auto [lo, hi] = std::minmax_element(ct.values.begin(), ct.values.end());
    throw Error(fmt::format("no organ voxel: none in the organ range {} apart from the mount and markers{} "
                            "(the image spans [{:g}, {:g}] HU)",
                            RangeText(options.organ_hu), options.roi_min_m ? ", within the region of interest" : "",
                            *lo, *hi),
                ct.source, "set the organ's HU range to the tissue's CT numbers, or give a label map");
  }
  const std::uint32_t label = options.seed_point_m ? SeedLabel(ct, box, components, options) : 1;
  report->organ_components = components.found;
  report->organ_voxels_dropped = candidate_voxels - components.sizes[label - 1];
  s.organ = FillHoles(Close(Pick(components.labels, label), RadiusVoxels(options.closing_radius_mm, ct.spacing_m)));
  return s;
}

// Step 6: the internal structures kept, as masks on the CT's grid.
std::vector<VoxelMask> SegmentInternal(const io::CtImage& ct, const Box& box, const HuImage* hu, const Solids& solids,
                                       const SegmentationOptions& options, SegmentationReport* report) {
  if (options.max_internal_structures == 0) return {};
  MaskImage::Pointer internal = Threshold(hu, options.internal_hu);
  Intersect(internal, Erode(solids.organ, 1));
  if (solids.markers) Subtract(internal, solids.markers);
  // A structure is kept when count * voxel volume >= the minimum volume.
  const double min_voxels = options.min_internal_volume_m3 / ct.spacing_m.prod();
  Box split_box;
  const Components structures = SplitTouching(internal, options.internal_split_depth_voxels,
                                              static_cast<std::size_t>(std::ceil(min_voxels - 1e-9)), &split_box);
  internal = nullptr;
  const int kept = std::min(static_cast<int>(structures.sizes.size()), options.max_internal_structures);
  report->internal_components = structures.found;
  report->internal_components_dropped = structures.found - kept;
  const Box on_grid{box.start + split_box.start, split_box.size};
  std::vector<VoxelMask> masks;
  for (int l = 1; l <= kept; ++l) masks.push_back(LabelOnGrid(ct, on_grid, structures.labels, l));
  return masks;
}

}  // namespace

VoxelMask VoxelMask::OnGridOf(const io::CtImage& image) {
  VoxelMask mask;
  mask.size = image.size;
  mask.spacing_m = image.spacing_m;
  mask.origin_m = image.origin_m;
  mask.direction = image.direction;
  mask.inside.assign(image.num_voxels(), 0);
  return mask;
}

std::size_t VoxelMask::Count() const { return static_cast<std::size_t>(std::count(inside.begin(), inside.end(), 1)); }

std::string SegmentationReport::Describe() const {
  return fmt::format("organ {:.1f} ml, {} voxels, S box ({:.1f}, {:.1f}, {:.1f}) .. ({:.1f}, {:.1f}, {:.1f}) mm, "
                     "median {:g} HU; {} candidate components ({} voxels dropped outside the organ's); mount {} "
                     "voxels; {} internal structures kept of {} found ({} dropped)",
                     organ_volume_ml, organ_voxels, organ_min_mm.x(), organ_min_mm.y(), organ_min_mm.z(),
                     organ_max_mm.x(), organ_max_mm.y(), organ_max_mm.z(), organ_median_hu, organ_components,
                     organ_voxels_dropped, mount_voxels, internal_voxels.size(), internal_components,
                     internal_components_dropped);
}

std::string SegmentationOptions::Validate() const {
  for (auto [range, name] : {std::pair{&organ_hu, "organ_hu"}, {&internal_hu, "internal_hu"}, {&mount_hu, "mount_hu"}}) {
    if (std::string problem = ValidateRange(*range, name); !problem.empty()) return problem;
  }
  if (marker_min_hu && !std::isfinite(*marker_min_hu)) return "marker_min_hu must be finite (or unset: no markers)";
  if (marker_margin_voxels < 0) return fmt::format("marker_margin_voxels must be >= 0, got {}", marker_margin_voxels);
  if (!(opening_radius_mm >= 0) || !(closing_radius_mm >= 0) || !std::isfinite(opening_radius_mm) ||
      !std::isfinite(closing_radius_mm)) {
    return fmt::format("opening_radius_mm ({:g}) and closing_radius_mm ({:g}) must be finite and >= 0",
                       opening_radius_mm, closing_radius_mm);
  }
  if (!(internal_split_depth_voxels > 0)) {
    return fmt::format("internal_split_depth_voxels must be positive, got {:g}", internal_split_depth_voxels);
  }
  if (!(min_internal_volume_m3 >= 0)) return "min_internal_volume_m3 must be >= 0";
  if (max_internal_structures < 0) {
    return fmt::format("max_internal_structures must be >= 0, got {}", max_internal_structures);
  }
  if (roi_min_m.has_value() != roi_max_m.has_value()) return "roi_min_m and roi_max_m must be given together";
  if (roi_min_m && (!roi_min_m->allFinite() || !roi_max_m->allFinite() ||
                    (roi_min_m->array() >= roi_max_m->array()).any())) {
    return fmt::format("the region of interest must have roi_min_m < roi_max_m on every axis, got {} .. {}",
                       Millimetres(*roi_min_m), Millimetres(*roi_max_m));
  }
  if (seed_point_m && !seed_point_m->allFinite()) return "seed_point_m must be finite";
  std::set<int> labels(internal_labels.begin(), internal_labels.end());
  if (labels.size() != internal_labels.size()) return "internal_labels repeat a label";
  if (organ_label == 0) return "organ_label must not be 0 (the background)";
  if (labels.count(0) || labels.count(organ_label) || (mount_label != 0 && labels.count(mount_label)) ||
      mount_label == organ_label) {
    return fmt::format("organ_label ({}), mount_label ({}) and internal_labels must be distinct and non-zero "
                       "(mount_label 0 means no mount)",
                       organ_label, mount_label);
  }
  return "";
}

Segmentation Segment(const io::CtImage& ct, const SegmentationOptions& options) {
  RequireValid(options, ct);
  if (!ct.values_are_hu) {
    throw Error("automatic segmentation needs CT numbers in HU, and this image's values were taken as stored "
                "(not HU)",
                ct.source, "give a label map (preop --labels), or the values' scale to HU (--intensity-scale)");
  }
  return Guarded(ct, [&] {
    const Box box = WorkingBox(ct, options);
    const HuImage::Pointer hu = WorkingImage(ct, box, options);
    Segmentation s;
    Solids solids = SegmentSolids(ct, box, hu, options, &s.report);
    s.internal = SegmentInternal(ct, box, hu, solids, options, &s.report);
    s.organ = MaskOnGrid(ct, box, solids.organ);
    s.mount = MaskOnGrid(ct, box, solids.mount);
    Summarise(ct, &s);
    LogSegmentation(s, ct.source);
    return s;
  });
}

namespace {

// One pass of the exact squared Euclidean distance transform (Felzenszwalb
// and Huttenlocher, "Distance transforms of sampled functions", 2012): along
// `axis` of a box of `size` voxels, each value becomes
// min over p of f(p) + (step (q - p))^2, the lower envelope of parabolas.
void SquaredDistanceAlong(int axis, double step, const Eigen::Vector3i& size, std::vector<double>* values) {
  const std::size_t stride = axis == 0 ? 1 : axis == 1 ? size.x() : static_cast<std::size_t>(size.x()) * size.y();
  const int n = size[axis];
  const double w = step * step;
  std::vector<double> f(n);
  std::vector<int> apex(n);             // the envelope's parabolas, by their apex
  std::vector<double> from(n + 1);      // where each begins to be the lowest
  const Eigen::Vector3i lines = size - Eigen::Vector3i::Unit(axis).cwiseProduct(size - Eigen::Vector3i::Ones());
  for (int c = 0; c < lines.z(); ++c)
    for (int b = 0; b < lines.y(); ++b)
      for (int a = 0; a < lines.x(); ++a) {
        const std::size_t first = a + size.x() * (static_cast<std::size_t>(b) + static_cast<std::size_t>(size.y()) * c);
        int parabolas = 0;
        for (int q = 0; q < n; ++q) {
          f[q] = (*values)[first + q * stride];
          if (!std::isfinite(f[q])) continue;
          while (parabolas > 0) {
            const int v = apex[parabolas - 1];
            const double meet = ((f[q] + w * q * q) - (f[v] + w * v * v)) / (2 * w * (q - v));
            if (meet > from[parabolas - 1]) {
              from[parabolas] = meet;
              break;
            }
            --parabolas;
          }
          if (parabolas == 0) from[0] = -std::numeric_limits<double>::infinity();
          apex[parabolas++] = q;
        }
        if (parabolas == 0) continue;  // nothing along this line: infinite throughout
        from[parabolas] = std::numeric_limits<double>::infinity();
        for (int q = 0, j = 0; q < n; ++q) {
          while (from[j + 1] < q) ++j;
          const double d = q - apex[j];
          (*values)[first + q * stride] = w * d * d + f[apex[j]];
        }
      }
}

// The distance from each voxel of a box to the nearest voxel where `inside`
// is set (0 there; infinite when none is), a step along axis d counting
// step[d].
std::vector<double> DistanceTo(const std::vector<std::uint8_t>& inside, const Eigen::Vector3i& size,
                               const Eigen::Vector3d& step) {
  std::vector<double> d(inside.size());
  for (std::size_t v = 0; v < inside.size(); ++v) d[v] = inside[v] ? 0.0 : std::numeric_limits<double>::infinity();
  for (int axis = 0; axis < 3; ++axis) SquaredDistanceAlong(axis, step[axis], size, &d);
  for (double& x : d) x = std::sqrt(x);
  return d;
}

}  // namespace

VoxelMask ClosedSolid(const VoxelMask& mask, double radius_mm) {
  // The ball is ITK's binary ball of RadiusVoxels(radius_mm) (R voxels along
  // each axis: the offsets o with sum (o_d / (R_d + 1/2))^2 <= 1), and the
  // closing is computed through two exact distance maps in that ball's
  // metric (dilate: within 1 of the mask; erode: farther than 1 from what
  // the dilation left out). Its cost does not grow with the radius, where a
  // structuring element costs its volume per voxel (23 voxels across at
  // 16 mm on a 0.7 mm grid). It works on the mask's bounding box padded by
  // the radius and a voxel, so its cost follows the organ, not the CT;
  // nothing grows in from beyond the grid.
  const Eigen::Vector3i radius_voxels = RadiusVoxels(radius_mm, mask.spacing_m);
  const Eigen::Vector3d step = (radius_voxels.cast<double>().array() + 0.5).inverse();
  const Eigen::Vector3i reach = radius_voxels + Eigen::Vector3i::Ones();
  MaskImage::Pointer whole = NewImage<MaskImage>(mask.size);
  std::copy(mask.inside.begin(), mask.inside.end(), whole->GetBufferPointer());
  const Box content = BoundingBox(whole, 0);
  whole = nullptr;
  if (content.num_voxels() == 0) return mask;
  const Box padded{content.start - reach, content.size + 2 * reach};
  const Box grid{Eigen::Vector3i::Zero(), mask.size};
  auto for_each_grid_voxel = [&](auto&& f) {  // f(index in padded, index in the mask's grid)
    std::size_t local = 0;
    for (int k = 0; k < padded.size.z(); ++k)
      for (int j = 0; j < padded.size.y(); ++j)
        for (int i = 0; i < padded.size.x(); ++i, ++local) {
          const Eigen::Vector3i g = padded.start + Eigen::Vector3i(i, j, k);
          if (grid.Contains(g)) f(local, mask.Index(g.x(), g.y(), g.z()));
        }
  };
  std::vector<std::uint8_t> v(padded.num_voxels(), 0);
  for_each_grid_voxel([&](std::size_t local, std::size_t global) { v[local] = mask.inside[global]; });
  std::vector<double> d = DistanceTo(v, padded.size, step);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = d[i] > 1;  // what the dilation leaves out
  d = DistanceTo(v, padded.size, step);
  MaskImage::Pointer image = NewImage<MaskImage>(padded.size);
  std::uint8_t* closed_box = image->GetBufferPointer();
  for (std::size_t i = 0; i < v.size(); ++i) closed_box[i] = d[i] > 1;  // eroded: farther than the ball from it
  try {
    image = FillHoles(image);
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("filling the closed organ's holes failed in ITK: ") + e.GetDescription(), "segmentation",
                "check the mask");
  }
  VoxelMask closed = mask;
  closed_box = image->GetBufferPointer();
  for_each_grid_voxel([&](std::size_t local, std::size_t global) { closed.inside[global] = closed_box[local]; });
  return closed;
}

Segmentation Segment(const io::CtImage& ct, const io::CtImage& labels, const SegmentationOptions& options) {
  RequireValid(options, ct);
  const double tolerance_m = 1e-3 * ct.spacing_m.minCoeff();
  if (labels.size != ct.size || !labels.spacing_m.isApprox(ct.spacing_m, 1e-6) ||
      (labels.origin_m - ct.origin_m).norm() > tolerance_m || !labels.direction.isApprox(ct.direction, 1e-6) ||
      labels.values.size() != ct.values.size()) {
    throw Error(fmt::format("label map on another grid: {} x {} x {} voxels of {} at {}, the CT {} x {} x {} "
                            "voxels of {} at {} (or their directions differ)",
                            labels.size.x(), labels.size.y(), labels.size.z(), Millimetres(labels.spacing_m),
                            Millimetres(labels.origin_m), ct.size.x(), ct.size.y(), ct.size.z(),
                            Millimetres(ct.spacing_m), Millimetres(ct.origin_m)),
                labels.source + " vs " + ct.source, "resample the label map onto the CT phase it was drawn on");
  }
  auto label_mask = [&](int label) {
    VoxelMask mask = VoxelMask::OnGridOf(ct);
    for (std::size_t v = 0; v < mask.inside.size(); ++v) mask.inside[v] = std::lround(labels.values[v]) == label;
    if (mask.Count() == 0) {
      throw Error(fmt::format("label {} is on no voxel of the label map", label), labels.source,
                  "name the labels the map uses (organ, mount and internal labels)");
    }
    return mask;
  };

  Segmentation s;
  VoxelMask organ_candidates = label_mask(options.organ_label);
  for (int label : options.internal_labels) {
    s.internal.push_back(label_mask(label));
    for (std::size_t v = 0; v < organ_candidates.inside.size(); ++v) organ_candidates.inside[v] |= s.internal.back().inside[v];
  }
  s.mount = options.mount_label != 0 ? label_mask(options.mount_label) : VoxelMask::OnGridOf(ct);
  return Guarded(ct, [&] {
    const Box all{Eigen::Vector3i::Zero(), ct.size};
    MaskImage::Pointer candidates = NewImage<MaskImage>(ct.size);
    std::copy(organ_candidates.inside.begin(), organ_candidates.inside.end(), candidates->GetBufferPointer());
    const std::size_t candidate_voxels = organ_candidates.Count();
    organ_candidates = VoxelMask{};
    const Components components = LabelComponents(candidates);
    candidates = nullptr;
    s.report.organ_components = components.found;
    s.report.organ_voxels_dropped = candidate_voxels - components.sizes.front();
    s.organ = MaskOnGrid(ct, all, FillHoles(Pick(components.labels, 1)));
    Summarise(ct, &s);
    LogSegmentation(s, labels.source);
    return s;
  });
}

}  // namespace dg::stages::preop
