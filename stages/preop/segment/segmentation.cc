#include "stages/preop/segment/segmentation.h"

#include <algorithm>
#include <cmath>
#include <map>
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
#include <itkSignedMaurerDistanceMapImageFilter.h>

#include "sim/error.h"
#include "sim/log.h"

namespace dg::stages::preop {
namespace {

using MaskImage = itk::Image<std::uint8_t, 3>;
using HuImage = itk::Image<float, 3>;
using LabelImage = itk::Image<std::uint32_t, 3>;
using Ball = itk::BinaryBallStructuringElement<std::uint8_t, 3>;

// The filters work in voxel units (radii in voxels, components by face
// adjacency), so the images carry the grid's size only; geometry stays in the
// VoxelMask.
template <class Image>
typename Image::Pointer NewImage(const Eigen::Vector3i& size) {
  typename Image::Pointer image = Image::New();
  typename Image::SizeType itk_size;
  for (int d = 0; d < 3; ++d) itk_size[d] = static_cast<itk::SizeValueType>(size[d]);
  image->SetRegions(typename Image::RegionType(itk_size));
  image->Allocate();
  return image;
}

HuImage::Pointer ToItk(const io::CtImage& ct) {
  HuImage::Pointer image = NewImage<HuImage>(ct.size);
  std::copy(ct.values.begin(), ct.values.end(), image->GetBufferPointer());
  return image;
}

MaskImage::Pointer ToItk(const VoxelMask& mask) {
  MaskImage::Pointer image = NewImage<MaskImage>(mask.size);
  std::copy(mask.inside.begin(), mask.inside.end(), image->GetBufferPointer());
  return image;
}

std::vector<std::uint8_t> Voxels(const MaskImage* image) {
  const std::uint8_t* begin = image->GetBufferPointer();
  return {begin, begin + image->GetBufferedRegion().GetNumberOfPixels()};
}

VoxelMask MaskOnGrid(const io::CtImage& ct, const MaskImage* image) {
  VoxelMask mask = VoxelMask::OnGridOf(ct);
  if (image) mask.inside = Voxels(image);
  return mask;
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
  filter->SetUpperThreshold(static_cast<float>(range.max_hu));
  filter->SetInsideValue(1);
  filter->SetOutsideValue(0);
  return Run(filter.GetPointer(), ct);
}

Ball BallOfRadius(int radius_voxels) {
  Ball ball;
  ball.SetRadius(static_cast<itk::SizeValueType>(radius_voxels));
  ball.CreateStructuringElement();
  return ball;
}

MaskImage::Pointer Dilate(MaskImage::Pointer mask, int radius_voxels) {
  if (radius_voxels == 0) return mask;
  auto filter = itk::BinaryDilateImageFilter<MaskImage, MaskImage, Ball>::New();
  filter->SetKernel(BallOfRadius(radius_voxels));
  filter->SetForegroundValue(1);
  filter->SetBackgroundValue(0);
  return Run(filter.GetPointer(), mask.GetPointer());
}

MaskImage::Pointer Erode(const MaskImage* mask, int radius_voxels) {
  auto filter = itk::BinaryErodeImageFilter<MaskImage, MaskImage, Ball>::New();
  filter->SetKernel(BallOfRadius(radius_voxels));
  filter->SetForegroundValue(1);
  filter->SetBackgroundValue(0);
  filter->SetBoundaryToForeground(false);  // what touches the grid's edge is not interior
  return Run(filter.GetPointer(), mask);
}

MaskImage::Pointer Open(const MaskImage* mask, int radius_voxels) {
  auto filter = itk::BinaryMorphologicalOpeningImageFilter<MaskImage, MaskImage, Ball>::New();
  filter->SetKernel(BallOfRadius(radius_voxels));
  filter->SetForegroundValue(1);
  filter->SetBackgroundValue(0);
  return Run(filter.GetPointer(), mask);
}

MaskImage::Pointer Close(const MaskImage* mask, int radius_voxels) {
  auto filter = itk::BinaryMorphologicalClosingImageFilter<MaskImage, MaskImage, Ball>::New();
  filter->SetKernel(BallOfRadius(radius_voxels));
  filter->SetForegroundValue(1);
  filter->SetSafeBorder(true);  // nothing grows in from beyond the grid
  return Run(filter.GetPointer(), mask);
}

MaskImage::Pointer FillHoles(const MaskImage* mask) {
  auto filter = itk::BinaryFillholeImageFilter<MaskImage>::New();
  filter->SetForegroundValue(1);
  filter->SetFullyConnected(false);
  return Run(filter.GetPointer(), mask);
}

// The connected components of a mask (face adjacency), largest first, as
// masks of their own.
std::vector<MaskImage::Pointer> Components(const MaskImage* mask) {
  auto label = itk::ConnectedComponentImageFilter<MaskImage, LabelImage>::New();
  label->SetFullyConnected(false);
  label->SetInput(mask);
  auto relabel = itk::RelabelComponentImageFilter<LabelImage, LabelImage>::New();
  relabel->SetSortByObjectSize(true);
  LabelImage::Pointer labels = Run(relabel.GetPointer(), Run(label.GetPointer(), mask).GetPointer());
  std::vector<MaskImage::Pointer> components;
  for (std::uint32_t l = 1; l <= relabel->GetNumberOfObjects(); ++l) {
    auto pick = itk::BinaryThresholdImageFilter<LabelImage, MaskImage>::New();
    pick->SetLowerThreshold(l);
    pick->SetUpperThreshold(l);
    pick->SetInsideValue(1);
    pick->SetOutsideValue(0);
    components.push_back(Run(pick.GetPointer(), labels.GetPointer()));
  }
  return components;
}

std::size_t CountInside(const MaskImage* mask) {
  const std::uint8_t* v = mask->GetBufferPointer();
  return static_cast<std::size_t>(std::count(v, v + mask->GetBufferedRegion().GetNumberOfPixels(), 1));
}

// The components of `mask` with structures that touch told apart: the
// watershed of the distance to the mask's boundary (each basin one blob's
// centre; a neck between two blobs is a ridge of the negated distance).
// Minima shallower than depth_voxels are merged, so a voxelised boundary's
// bumps do not split one blob. Each basin is cut back to the mask.
std::vector<MaskImage::Pointer> SplitTouching(const MaskImage* mask, double depth_voxels) {
  auto distance = itk::SignedMaurerDistanceMapImageFilter<MaskImage, HuImage>::New();
  distance->SetInsideIsPositive(false);  // negative inside: the blobs' centres are minima
  distance->SetSquaredDistance(false);
  distance->SetUseImageSpacing(false);
  distance->SetBackgroundValue(0);
  auto watershed = itk::MorphologicalWatershedImageFilter<HuImage, LabelImage>::New();
  watershed->SetLevel(static_cast<float>(depth_voxels));
  watershed->SetMarkWatershedLine(false);
  watershed->SetFullyConnected(false);
  LabelImage::Pointer basins = Run(watershed.GetPointer(), Run(distance.GetPointer(), mask).GetPointer());
  std::uint32_t* label = basins->GetBufferPointer();
  const std::uint8_t* inside = mask->GetBufferPointer();
  const std::size_t n = mask->GetBufferedRegion().GetNumberOfPixels();
  std::map<std::uint32_t, MaskImage::Pointer> parts;
  for (std::size_t v = 0; v < n; ++v) {
    if (!inside[v]) continue;
    MaskImage::Pointer& part = parts[label[v]];
    if (!part) {
      part = MaskImage::New();
      part->SetRegions(mask->GetBufferedRegion());
      part->Allocate(/*initializePixels=*/true);
    }
    part->GetBufferPointer()[v] = 1;
  }
  std::vector<MaskImage::Pointer> components;
  for (const auto& [basin, part] : parts) {
    for (MaskImage::Pointer& piece : Components(part)) components.push_back(piece);
  }
  std::stable_sort(components.begin(), components.end(), [](const MaskImage::Pointer& a, const MaskImage::Pointer& b) {
    return CountInside(a) > CountInside(b);
  });
  return components;
}

// keep & ~remove, voxel by voxel, in place.
void Subtract(MaskImage* keep, const MaskImage* remove) {
  std::uint8_t* k = keep->GetBufferPointer();
  const std::uint8_t* r = remove->GetBufferPointer();
  for (std::size_t i = 0, n = keep->GetBufferedRegion().GetNumberOfPixels(); i < n; ++i) k[i] &= !r[i];
}

// keep & within, voxel by voxel, in place.
void Intersect(MaskImage* keep, const MaskImage* within) {
  std::uint8_t* k = keep->GetBufferPointer();
  const std::uint8_t* w = within->GetBufferPointer();
  for (std::size_t i = 0, n = keep->GetBufferedRegion().GetNumberOfPixels(); i < n; ++i) k[i] &= w[i];
}

// The largest component of `candidates`, holes filled, and how many candidate
// voxels lay outside it; null when there is no candidate.
MaskImage::Pointer LargestSolid(const MaskImage* candidates, int closing_radius_voxels, std::size_t* dropped) {
  std::vector<MaskImage::Pointer> components = Components(candidates);
  if (components.empty()) return nullptr;
  *dropped = CountInside(candidates) - CountInside(components.front());
  MaskImage::Pointer solid = components.front();
  if (closing_radius_voxels > 0) solid = Close(solid, closing_radius_voxels);
  return FillHoles(solid);
}

std::string Millimetres(const Eigen::Vector3d& v_m) {
  return fmt::format("({:g}, {:g}, {:g}) mm", 1e3 * v_m.x(), 1e3 * v_m.y(), 1e3 * v_m.z());
}

std::string RangeText(const HuRange& range) { return fmt::format("[{:g}, {:g}] HU", range.min_hu, range.max_hu); }

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

void LogSegmentation(const Segmentation& s, const std::string& source) {
  Logger("stages").info("segmented {}: organ {} voxels ({} dropped outside its largest component), mount {}, "
                        "{} internal structures ({} small components dropped)",
                        source, s.report.organ_voxels, s.report.organ_voxels_dropped, s.report.mount_voxels,
                        s.internal.size(), s.report.internal_components_dropped);
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

std::string SegmentationOptions::Validate() const {
  for (auto [range, name] : {std::pair{&organ_hu, "organ_hu"}, {&internal_hu, "internal_hu"}, {&mount_hu, "mount_hu"}}) {
    if (std::string problem = ValidateRange(*range, name); !problem.empty()) return problem;
  }
  if (!std::isfinite(marker_min_hu)) return "marker_min_hu must be finite";
  if (marker_margin_voxels < 0 || closing_radius_voxels < 0) {
    return fmt::format("marker_margin_voxels ({}) and closing_radius_voxels ({}) must be >= 0", marker_margin_voxels,
                       closing_radius_voxels);
  }
  if (!(internal_split_depth_voxels > 0)) {
    return fmt::format("internal_split_depth_voxels must be positive, got {:g}", internal_split_depth_voxels);
  }
  if (!(min_internal_volume_m3 >= 0)) return "min_internal_volume_m3 must be >= 0";
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
  return Guarded(ct, [&] {
    const HuImage::Pointer hu = ToItk(ct);
    Segmentation s;

    const std::vector<MaskImage::Pointer> mounts = Components(Threshold(hu, options.mount_hu));
    const MaskImage::Pointer mount = mounts.empty() ? nullptr : mounts.front();
    s.mount = MaskOnGrid(ct, mount);

    const MaskImage::Pointer markers =
        Dilate(Threshold(hu, {options.marker_min_hu, HUGE_VAL}), options.marker_margin_voxels);

    MaskImage::Pointer candidates = Threshold(hu, options.organ_hu);
    if (mount) Subtract(candidates, mount);
    Subtract(candidates, markers);
    candidates = Open(candidates, 1);
    const MaskImage::Pointer organ =
        LargestSolid(candidates, options.closing_radius_voxels, &s.report.organ_voxels_dropped);
    if (!organ) {
      const auto [lo, hi] = std::minmax_element(ct.values.begin(), ct.values.end());
      throw Error(fmt::format("no organ voxel: none in the organ range {} apart from the mount and markers "
                              "(the image spans [{:g}, {:g}] HU)",
                              RangeText(options.organ_hu), *lo, *hi),
                  ct.source, "set the organ's HU range to the tissue's CT numbers, or give a label map");
    }
    s.organ = MaskOnGrid(ct, organ);

    MaskImage::Pointer internal = Threshold(hu, options.internal_hu);
    Intersect(internal, Erode(organ, 1));
    Subtract(internal, markers);
    const double voxel_m3 = ct.spacing_m.prod();
    for (const MaskImage::Pointer& component : SplitTouching(internal, options.internal_split_depth_voxels)) {
      if (static_cast<double>(CountInside(component)) * voxel_m3 < options.min_internal_volume_m3) {
        ++s.report.internal_components_dropped;
        continue;
      }
      s.internal.push_back(MaskOnGrid(ct, component));
    }

    s.report.organ_voxels = s.organ.Count();
    s.report.mount_voxels = s.mount.Count();
    for (const VoxelMask& m : s.internal) s.report.internal_voxels.push_back(m.Count());
    LogSegmentation(s, ct.source);
    return s;
  });
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
    s.organ = MaskOnGrid(ct, LargestSolid(ToItk(organ_candidates), 0, &s.report.organ_voxels_dropped));
    s.report.organ_voxels = s.organ.Count();
    s.report.mount_voxels = s.mount.Count();
    for (const VoxelMask& m : s.internal) s.report.internal_voxels.push_back(m.Count());
    LogSegmentation(s, labels.source);
    return s;
  });
}

}  // namespace dg::stages::preop
