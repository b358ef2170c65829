#include "stages/preop/motion/motion_registration.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <vector>

#include "stages/preop/motion/itk_images.h"  // first: it settles Eigen before ITK's
#include <ceres/gradient_problem.h>
#include <ceres/gradient_problem_solver.h>
#include <itkBSplineTransformParametersAdaptor.h>
#include <itkDisplacementFieldJacobianDeterminantFilter.h>
#include <itkImageRegionIteratorWithIndex.h>
#include <itkLinearInterpolateImageFunction.h>
#include <itkMattesMutualInformationImageToImageMetric.h>
#include <itkMinimumMaximumImageCalculator.h>
#include <itkSingleValuedCostFunction.h>
#include <itkRecursiveGaussianImageFilter.h>
#include <itkTransformToDisplacementFieldFilter.h>

#include "sim/error.h"
#include "stages/preop/motion/cubic_interpolant.h"
#include "stages/preop/motion/grid_mean_squares.h"

namespace dg::stages::preop {
namespace {

using registration::BSpline;
using registration::CubicInterpolant;
using registration::DomainOf;
using registration::Image;
using registration::kDim;
using registration::kMmPerM;
using registration::MakeGridMeanSquares;
using registration::SetDomain;
using registration::ToItkImage;

using VectorImage = itk::Image<itk::Vector<float, kDim>, kDim>;

// The metric between fixed (every voxel a sample) and moving through
// transform, on one thread.
itk::SingleValuedCostFunction::Pointer MakeMetric(MotionMetric kind, const Image::Pointer& fixed,
                                                  const Image::Pointer& moving, const BSpline::Pointer& transform,
                                                  double bending_weight) {
  if (kind == MotionMetric::kMeanSquares) {
    return MakeGridMeanSquares(fixed, moving, transform.GetPointer(), bending_weight);
  }
  const auto mattes = itk::MattesMutualInformationImageToImageMetric<Image, Image>::New();
  mattes->SetNumberOfHistogramBins(50);
  mattes->SetFixedImage(fixed);
  mattes->SetMovingImage(moving);
  mattes->SetFixedImageRegion(fixed->GetBufferedRegion());
  mattes->SetTransform(transform);
  mattes->SetInterpolator(itk::LinearInterpolateImageFunction<Image, double>::New());
  mattes->SetUseAllPixels(true);
  mattes->SetNumberOfWorkUnits(1);
  mattes->Initialize();
  return mattes.GetPointer();
}

// An ITK metric as Ceres sees it. The optimiser is Ceres's L-BFGS rather than
// ITK's L-BFGS-B: that one is f2c'd Fortran whose locals are process-wide
// statics, so registrations of several phases at once trample each other's
// iteration state (wrong results, now and then a crash).
class MetricFunction final : public ceres::FirstOrderFunction {
 public:
  explicit MetricFunction(itk::SingleValuedCostFunction::Pointer metric) : metric_(std::move(metric)) {}

  bool Evaluate(const double* parameters, double* cost, double* gradient) const override {
    const int n = NumParameters();
    itk::SingleValuedCostFunction::ParametersType x(n);
    std::copy(parameters, parameters + n, x.data_block());
    if (!gradient) {
      *cost = metric_->GetValue(x);
      return std::isfinite(*cost);
    }
    itk::SingleValuedCostFunction::DerivativeType derivative;
    metric_->GetValueAndDerivative(x, *cost, derivative);
    std::copy(derivative.begin(), derivative.end(), gradient);
    return std::isfinite(*cost);
  }
  int NumParameters() const override { return static_cast<int>(metric_->GetNumberOfParameters()); }

 private:
  itk::SingleValuedCostFunction::Pointer metric_;
};

// The number of B-spline intervals per axis so that control points are about
// spacing_mm apart over the image's extent (at least one interval).
BSpline::MeshSizeType MeshSize(const Image::Pointer& image, double spacing_mm) {
  BSpline::MeshSizeType mesh;
  for (unsigned d = 0; d < kDim; ++d) {
    const double extent_mm = image->GetSpacing()[d] * double(image->GetLargestPossibleRegion().GetSize(d) - 1);
    mesh[d] = std::max<unsigned>(1, static_cast<unsigned>(std::lround(extent_mm / spacing_mm)));
  }
  return mesh;
}

// det(I + du/dx) over the fixed image's voxels. ITK's determinant filter
// differentiates along the voxel axes, so the displacements are first
// expressed in those axes (D^T u): then its matrix is D^T (du/dx) D, whose
// determinant with I added is that of I + du/dx.
std::pair<double, double> JacobianRange(const BSpline::Pointer& transform, const Image::Pointer& fixed) {
  using FieldFilter = itk::TransformToDisplacementFieldFilter<VectorImage, double>;
  const FieldFilter::Pointer field_filter = FieldFilter::New();
  field_filter->SetTransform(transform);
  field_filter->SetReferenceImage(fixed);
  field_filter->SetUseReferenceImage(true);
  field_filter->SetNumberOfWorkUnits(1);
  field_filter->Update();
  const VectorImage::Pointer field = field_filter->GetOutput();
  const Image::DirectionType& D = fixed->GetDirection();
  VectorImage::PixelType* u = field->GetBufferPointer();
  for (size_t v = 0; v < field->GetLargestPossibleRegion().GetNumberOfPixels(); ++v) {
    itk::Vector<float, kDim> in_voxel_axes;
    for (unsigned a = 0; a < kDim; ++a) {
      double sum = 0;
      for (unsigned b = 0; b < kDim; ++b) sum += D(b, a) * u[v][b];
      in_voxel_axes[a] = static_cast<float>(sum);
    }
    u[v] = in_voxel_axes;
  }
  using JacobianFilter = itk::DisplacementFieldJacobianDeterminantFilter<VectorImage, double>;
  const JacobianFilter::Pointer jacobian = JacobianFilter::New();
  jacobian->SetInput(field);
  jacobian->SetUseImageSpacing(true);
  jacobian->SetNumberOfWorkUnits(1);
  jacobian->Update();
  using MinMax = itk::MinimumMaximumImageCalculator<JacobianFilter::OutputImageType>;
  const MinMax::Pointer range = MinMax::New();
  range->SetImage(jacobian->GetOutput());
  range->Compute();
  return {range->GetMinimum(), range->GetMaximum()};
}

// Sampling factors along each axis: every factor-th voxel.
using Factors = std::array<unsigned, kDim>;

// Every factor-th voxel along axis d, each sample placed at the voxel it
// copies (the samples centred on the image to within half a voxel; where
// ITK's filter places them right, the same samples). Not ITK's
// ShrinkImageFilter: that centres its output grid on the input's and copies
// the voxel nearest each output point, so along an axis of 2m voxels (and of
// 4m + 2 at factor 4) every sample lies half a voxel from the voxel it holds,
// and the fixed image of each shrunk level is shifted by half a voxel along
// that axis (1.5 mm on a 3 mm CT), which the finest level only partly undoes.
Image::Pointer ShrunkAlong(const Image::Pointer& image, unsigned d, unsigned factor) {
  if (factor == 1) return image;
  const Image::RegionType& region = image->GetBufferedRegion();
  const long voxels = static_cast<long>(region.GetSize(d));
  const long samples = std::max(1L, voxels / long(factor));  // as many as ITK's filter takes
  Image::IndexType first = region.GetIndex();
  first[d] += (voxels - 1 - (samples - 1) * long(factor)) / 2;
  Image::RegionType shrunk_region;
  shrunk_region.SetSize(region.GetSize());
  shrunk_region.SetSize(d, samples);
  Image::SpacingType spacing = image->GetSpacing();
  spacing[d] *= factor;
  Image::PointType origin;
  image->TransformIndexToPhysicalPoint(first, origin);
  const Image::Pointer shrunk = Image::New();
  shrunk->SetRegions(shrunk_region);
  shrunk->SetSpacing(spacing);
  shrunk->SetOrigin(origin);
  shrunk->SetDirection(image->GetDirection());
  shrunk->Allocate();
  for (itk::ImageRegionIteratorWithIndex<Image> it(shrunk, shrunk_region); !it.IsAtEnd(); ++it) {
    Image::IndexType source = it.GetIndex();
    source[d] = first[d] + long(factor) * source[d];
    it.Set(image->GetPixel(source));
  }
  return shrunk;
}

// `image` as a level sees it: smoothed along each axis by half that axis's
// sampling factor (so that samples taken at that factor do not alias; no blur
// along an axis sampled fully), and every shrink[d]-th voxel kept. Axis by
// axis, each blur working on the voxels the previous axes kept; the blurs act
// on separate axes, so the voxels kept are those of blurring the whole image
// first.
Image::Pointer SmoothedAndShrunk(Image::Pointer image, const Factors& factors, const Factors& shrink) {
  for (unsigned d = 0; d < kDim; ++d) {
    if (factors[d] > 1) {
      using Filter = itk::RecursiveGaussianImageFilter<Image, Image>;
      const Filter::Pointer filter = Filter::New();
      filter->SetInput(image);
      filter->SetDirection(d);
      filter->SetSigma(0.5 * factors[d] * image->GetSpacing()[d]);
      filter->SetZeroOrder();
      filter->SetNumberOfWorkUnits(1);
      filter->Update();
      image = filter->GetOutput();
      image->DisconnectPipeline();
    }
    image = ShrunkAlong(image, d, shrink[d]);
  }
  return image;
}

// The fixed image's samples at a level: every factor-th voxel of the blurred
// image.
Image::Pointer FixedSamples(const Image::Pointer& fixed, const Factors& factors) {
  return SmoothedAndShrunk(fixed, factors, factors);
}

// The moving image at a level, interpolated between its voxels: blurred as
// the fixed one, and every fourth of the sampling factor's voxels kept. The
// blur's sigma is then at least two kept voxels, where the cubic interpolant
// of the kept voxels differs from the blurred image by under 1e-4 of its
// contrast; with every voxel kept, each level of each phase would prefilter
// and interpolate a fine scan's full grid, and with every second (a sigma of
// one kept voxel), the coarse levels of an unmoving phase saw 4 HU (RMS) of
// interpolation error as motion (docs/preop.md, "Where and how densely").
Image::Pointer MovingLevel(const Image::Pointer& moving, const Factors& factors) {
  Factors kept;
  for (unsigned d = 0; d < kDim; ++d) kept[d] = std::max(1u, factors[d] / 4);
  return SmoothedAndShrunk(moving, factors, kept);
}

// The finest level's sampling factors: the voxels along each axis, every
// voxel where they are at least finest_sample_mm apart, and every second or
// more where they are finer (a 0.6 mm in-plane grid is sampled at 1.2 mm).
Factors FinestFactors(const Image::Pointer& image, const MotionRegistrationOptions& options) {
  Factors factors;
  for (unsigned d = 0; d < kDim; ++d) {
    factors[d] = std::max(1u, static_cast<unsigned>(std::floor(options.finest_sample_mm / image->GetSpacing()[d] + 1e-9)));
  }
  return factors;
}

Factors Times(Factors factors, unsigned shrink) {
  for (unsigned& f : factors) f *= shrink;
  return factors;
}

// One level: the transform (already on this level's grid) optimised in place
// against the level's fixed samples and the moving image blurred alike. The
// metric is returned, to report the finest level's figures.
itk::SingleValuedCostFunction::Pointer RunLevel(const Image::Pointer& fixed_samples, const Image::Pointer& moving,
                                                const BSpline::Pointer& transform,
                                                const MotionRegistrationOptions& options,
                                                PhaseRegistrationReport* report) {
  const itk::SingleValuedCostFunction::Pointer metric =
      MakeMetric(options.metric, fixed_samples, moving, transform, options.bending_weight);
  BSpline::ParametersType parameters = transform->GetParameters();
  ceres::GradientProblemSolver::Options solver;
  solver.line_search_direction_type = ceres::LBFGS;
  solver.max_lbfgs_rank = 7;
  solver.max_num_iterations = options.max_iterations;
  solver.function_tolerance = 1e-9;  // relative decrease of the metric per iteration
  solver.gradient_tolerance = 1e-6;
  solver.logging_type = ceres::SILENT;
  ceres::GradientProblemSolver::Summary summary;
  ceres::Solve(solver, ceres::GradientProblem(new MetricFunction(metric)), parameters.data_block(), &summary);
  if (summary.termination_type == ceres::FAILURE) {
    throw Error("the B-spline optimisation failed: " + summary.message, "motion registration",
                "check that the phase shows the same anatomy as phase 0 on the same grid");
  }
  // By value: SetParameters would keep a reference to this local array.
  transform->SetParametersByValue(parameters);
  report->iterations += static_cast<int>(summary.iterations.size()) - 1;  // the first entry is the start
  report->evaluations += summary.num_gradient_evaluations;
  report->stop_condition = summary.message;
  return metric;
}

}  // namespace

// The spline (in millimetres) and the grid it is defined over.
struct PhaseDeformation::Spline {
  BSpline::Pointer transform;
  io::CtImage grid;  // phase 0's geometry, no values
};

// Phase 0 as the levels compare against it, coarse to fine.
struct PhaseRegistration::Levels {
  io::CtImage grid;                  // the part of phase 0 registered (RegistrationGrid), no values
  std::vector<Factors> factors;      // each level's sampling factors
  std::vector<Image::Pointer> fixed_samples;  // FixedSamples at those factors; read only once built
};

PhaseRegistration::PhaseRegistration(const std::vector<io::CtImage>& phases, const MotionRegistrationOptions& options)
    : phases_(phases), options_(options) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw Error(problem, "MotionRegistrationOptions", "set the option in range");
  }
  CheckPhases(phases);
  auto levels = std::make_unique<Levels>();
  levels->grid = RegistrationGrid(phases[0], options);
  const Image::Pointer fixed = ToItkImage(phases[0], levels->grid);
  const Factors finest = FinestFactors(fixed, options);
  for (int level = 0; level < options.levels; ++level) {
    levels->factors.push_back(Times(finest, 1u << (options.levels - 1 - level)));
    levels->fixed_samples.push_back(FixedSamples(fixed, levels->factors.back()));
  }
  levels_ = std::move(levels);
}

PhaseRegistration::~PhaseRegistration() = default;

// The spline's domain is phase 0's whole grid, whatever part of it the images
// cover: its control points are then where a registration of the whole grid
// puts them, whatever the region. Control points with no sample near them
// keep the identity.
PhaseDeformation PhaseRegistration::Register(int k) const {
  if (k < 1 || k >= static_cast<int>(phases_.size())) {
    throw Error("phase " + std::to_string(k) + " is not one of phases 1 to " + std::to_string(phases_.size() - 1),
                "motion registration", "register each phase after the first to the first");
  }
  const auto start = std::chrono::steady_clock::now();
  PhaseRegistrationReport report;
  report.phase = k;
  auto spline = std::make_shared<PhaseDeformation::Spline>();
  spline->grid = levels_->grid;
  try {
    const Image::Pointer moving = ToItkImage(phases_[k], levels_->grid);
    const Image::Pointer domain = DomainOf(phases_[0]);
    const BSpline::Pointer transform = BSpline::New();
    itk::SingleValuedCostFunction::Pointer metric;
    for (int level = 0; level < options_.levels; ++level) {
      const unsigned shrink = 1u << (options_.levels - 1 - level);
      const BSpline::MeshSizeType mesh = MeshSize(domain, options_.grid_spacing_mm * shrink);
      if (level == 0) {
        SetDomain(domain, mesh, transform.GetPointer());
      } else {
        // The coarser spline refined exactly onto the finer grid.
        using Adaptor = itk::BSplineTransformParametersAdaptor<BSpline>;
        const Adaptor::Pointer adaptor = Adaptor::New();
        adaptor->SetTransform(transform);
        adaptor->SetRequiredTransformDomainOrigin(transform->GetTransformDomainOrigin());
        adaptor->SetRequiredTransformDomainDirection(transform->GetTransformDomainDirection());
        adaptor->SetRequiredTransformDomainPhysicalDimensions(transform->GetTransformDomainPhysicalDimensions());
        adaptor->SetRequiredTransformDomainMeshSize(mesh);
        adaptor->AdaptTransformParameters();
      }
      metric = RunLevel(levels_->fixed_samples[level], MovingLevel(moving, levels_->factors[level]), transform,
                        options_, &report);
    }
    const BSpline::ParametersType result = transform->GetParameters();
    report.metric_before = metric->GetValue(BSpline::ParametersType(result.Size(), 0.0));
    report.metric_after = metric->GetValue(result);
    transform->SetParametersByValue(result);
    std::tie(report.min_jacobian, report.max_jacobian) = JacobianRange(transform, levels_->fixed_samples.back());
    spline->transform = transform;
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("ITK failed to register the phase: ") + e.GetDescription(),
                "phase " + std::to_string(k) + " (" + phases_[k].source + ")",
                "check that the phase shows the same anatomy as phase 0 on the same grid");
  }
  report.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return PhaseDeformation(std::move(spline), report);
}


void CheckPhases(const std::vector<io::CtImage>& phases) {
  if (phases.size() < 2) {
    throw Error("motion registration needs at least two phases, got " + std::to_string(phases.size()),
                phases.empty() ? "the 4D CT" : phases[0].source, "give every phase of the 4D CT");
  }
  const io::CtImage& first = phases[0];
  for (size_t k = 0; k < phases.size(); ++k) {
    const io::CtImage& phase = phases[k];
    const std::string where = "phase " + std::to_string(k) + " (" + phase.source + ")";
    if (phase.size.minCoeff() < 4) {
      throw Error("the grid is " + std::to_string(phase.size.x()) + "x" + std::to_string(phase.size.y()) + "x" +
                      std::to_string(phase.size.z()) + " voxels, too small to register",
                  where, "give a volume of at least 4 voxels along each axis");
    }
    if (phase.values.size() != phase.num_voxels()) {
      throw Error("holds " + std::to_string(phase.values.size()) + " values for " +
                      std::to_string(phase.num_voxels()) + " voxels",
                  where, "read the phase with the io/ct readers, which fill the grid");
    }
    constexpr double kTolerance_m = 1e-7;
    const bool same_grid = phase.size == first.size &&
                           (phase.spacing_m - first.spacing_m).cwiseAbs().maxCoeff() < kTolerance_m &&
                           (phase.origin_m - first.origin_m).cwiseAbs().maxCoeff() < kTolerance_m &&
                           (phase.direction - first.direction).cwiseAbs().maxCoeff() < 1e-6;
    if (!same_grid) {
      std::ostringstream what;
      what << "the grid (size " << phase.size.transpose() << ", spacing_m " << phase.spacing_m.transpose()
           << ", origin_m " << phase.origin_m.transpose() << ") differs from phase 0's (size " << first.size.transpose()
           << ", spacing_m " << first.spacing_m.transpose() << ", origin_m " << first.origin_m.transpose()
           << ") or its direction does";
      throw Error(what.str(), where, "give phases of one 4D CT, all reconstructed on the same grid");
    }
  }
}

std::string MotionRegistrationOptions::Validate() const {
  if (!(grid_spacing_mm > 0) || !std::isfinite(grid_spacing_mm)) {
    return "grid_spacing_mm must be a positive number of millimetres, got " + std::to_string(grid_spacing_mm);
  }
  if (!(finest_sample_mm > 0) || !std::isfinite(finest_sample_mm)) {
    return "finest_sample_mm must be a positive number of millimetres, got " + std::to_string(finest_sample_mm);
  }
  if (region_min_S_m.has_value() != region_max_S_m.has_value()) {
    return "region_min_S_m and region_max_S_m must be given together";
  }
  if (region_min_S_m && (!region_min_S_m->allFinite() || !region_max_S_m->allFinite() ||
                         (region_min_S_m->array() > region_max_S_m->array()).any())) {
    return "the region must have finite corners with region_min_S_m <= region_max_S_m on every axis";
  }
  if (levels < 1 || levels > 6) return "levels must be 1 to 6, got " + std::to_string(levels);
  if (max_iterations < 1) return "max_iterations must be at least 1, got " + std::to_string(max_iterations);
  if (metric != MotionMetric::kMeanSquares && metric != MotionMetric::kMutualInformation) {
    return "metric is not a MotionMetric";
  }
  if (!(bending_weight >= 0) || !std::isfinite(bending_weight)) {
    return "bending_weight must be zero or a positive number, got " + std::to_string(bending_weight);
  }
  return {};
}

PhaseDeformation::PhaseDeformation() = default;

PhaseDeformation::PhaseDeformation(std::shared_ptr<const Spline> spline, PhaseRegistrationReport report)
    : spline_(std::move(spline)), report_(std::move(report)) {}

std::vector<double> PhaseDeformation::FixedParameters() const {
  if (!spline_) return {};
  const BSpline::FixedParametersType& fixed = spline_->transform->GetFixedParameters();
  return {fixed.begin(), fixed.end()};
}

std::vector<double> PhaseDeformation::Parameters() const {
  if (!spline_) return {};
  const BSpline::ParametersType& parameters = spline_->transform->GetParameters();
  return {parameters.begin(), parameters.end()};
}

PhaseDeformation PhaseDeformation::FromParameters(const std::vector<double>& fixed_parameters,
                                                  const std::vector<double>& parameters, const io::CtImage& grid,
                                                  PhaseRegistrationReport report) {
  auto spline = std::make_shared<Spline>();
  spline->grid = grid.GridOnly();
  spline->transform = BSpline::New();
  try {
    BSpline::FixedParametersType fixed(fixed_parameters.size());
    std::copy(fixed_parameters.begin(), fixed_parameters.end(), fixed.begin());
    spline->transform->SetFixedParameters(fixed);
    if (spline->transform->GetNumberOfParameters() != parameters.size()) {
      throw Error("a B-spline of " + std::to_string(parameters.size()) + " parameters where its grid has " +
                      std::to_string(spline->transform->GetNumberOfParameters()),
                  grid.source, "register the phase again");
    }
    BSpline::ParametersType values(parameters.size());
    std::copy(parameters.begin(), parameters.end(), values.begin());
    spline->transform->SetParametersByValue(values);
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("not a B-spline: ") + e.GetDescription(), grid.source, "register the phase again");
  }
  return PhaseDeformation(std::move(spline), std::move(report));
}

Eigen::Matrix3Xd PhaseDeformation::Displacements(const Eigen::Matrix3Xd& points_S_m) const {
  Eigen::Matrix3Xd u = Eigen::Matrix3Xd::Zero(3, points_S_m.cols());
  if (!spline_) return u;
  const io::CtImage& grid = spline_->grid;
  const Eigen::Matrix3d to_index = (grid.direction * grid.spacing_m.asDiagonal()).inverse();
  for (Eigen::Index i = 0; i < points_S_m.cols(); ++i) {
    const Eigen::Vector3d index = to_index * (points_S_m.col(i) - grid.origin_m);
    // The spline is defined over the voxels' centres and half a voxel beyond
    // them (the image's extent). An organ cut by the field of view has its
    // surface there, and smoothing moves some of it a little further out:
    // up to kOutsideReach_voxels beyond, a point takes the displacement of the
    // nearest point of the extent; farther out it is refused.
    constexpr double kEdge = 0.5, kOutsideReach_voxels = 1.0;
    const Eigen::Array3d last = grid.size.cast<double>().array() - 1;
    if ((index.array() < -kEdge - kOutsideReach_voxels).any() ||
        (index.array() > last + kEdge + kOutsideReach_voxels).any()) {
      std::ostringstream what;
      what << "point " << i << " at " << points_S_m.col(i).transpose()
           << " m lies outside the grid the motion was registered on";
      throw Error(what.str(), grid.source,
                  "give points inside the phase-0 image (the mesh segmented from it) and inside the registration's "
                  "region");
    }
    const Eigen::Vector3d within = index.array().max(-kEdge + 1e-9).min(last + kEdge - 1e-9).matrix();
    const Eigen::Vector3d point_m = grid.origin_m + grid.direction * grid.spacing_m.cwiseProduct(within);
    BSpline::InputPointType X;
    for (unsigned d = 0; d < kDim; ++d) X[d] = point_m[d] * kMmPerM;
    const BSpline::OutputPointType x = spline_->transform->TransformPoint(X);
    for (unsigned d = 0; d < kDim; ++d) u(d, i) = (x[d] - X[d]) / kMmPerM;
  }
  return u;
}

// The region's margin, in finest control spacings. A cubic B-spline moves a
// point with the control points within two spacings of it; two spacings of
// image beyond the outermost point give each of those control points its
// whole support of samples. With one, control points half outside the image
// were held by half their samples (on the real abdominal CT, nodes at the
// region's edge off by 1.4 mm).
constexpr double kRegionMarginSpacings = 2;

io::CtImage RegistrationGrid(const io::CtImage& phase0, const MotionRegistrationOptions& options) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw Error(problem, "MotionRegistrationOptions", "set the option in range");
  }
  io::CtImage grid = phase0.GridOnly();
  if (!options.region_min_S_m) return grid;
  const Eigen::Vector3d margin_m = Eigen::Vector3d::Constant(kRegionMarginSpacings * options.grid_spacing_mm / kMmPerM);
  const Eigen::Vector3d lo_m = *options.region_min_S_m - margin_m, hi_m = *options.region_max_S_m + margin_m;
  // The box's corners in voxel indices (any direction of the grid).
  const Eigen::Matrix3d to_index = (phase0.direction * phase0.spacing_m.asDiagonal()).inverse();
  Eigen::Array3d first = Eigen::Array3d::Constant(std::numeric_limits<double>::infinity()), last = -first;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d x(corner & 1 ? hi_m.x() : lo_m.x(), corner & 2 ? hi_m.y() : lo_m.y(),
                            corner & 4 ? hi_m.z() : lo_m.z());
    const Eigen::Array3d index = to_index * (x - phase0.origin_m);
    first = first.min(index), last = last.max(index);
  }
  const Eigen::Array3i size = phase0.size.array();
  if ((last < -0.5).any() || (first > size.cast<double>() - 0.5).any()) {
    throw Error("the region to register misses the CT's grid", phase0.source,
                "give a region (the organ's mesh and fiducials) inside the phase-0 image");
  }
  Eigen::Array3i lo = first.floor().cast<int>().max(0), hi = last.ceil().cast<int>().min(size - 1);
  for (int d = 0; d < 3; ++d) {  // at least 4 voxels, for the cubic interpolant
    while (hi[d] - lo[d] < 3 && (lo[d] > 0 || hi[d] < size[d] - 1)) {
      if (lo[d] > 0) --lo[d];
      if (hi[d] - lo[d] < 3 && hi[d] < size[d] - 1) ++hi[d];
    }
  }
  grid.origin_m = phase0.PointOf(lo.x(), lo.y(), lo.z());
  grid.size = (hi - lo + 1).matrix();
  return grid;
}

std::vector<PhaseDeformation> RegisterPhases(const std::vector<io::CtImage>& phases,
                                             const MotionRegistrationOptions& options) {
  const PhaseRegistration registration(phases, options);
  std::vector<PhaseDeformation> deformations(phases.size());
  for (int k = 1; k < static_cast<int>(phases.size()); ++k) deformations[k] = registration.Register(k);
  return deformations;
}

CtSamples SampleCubic(const io::CtImage& ct, const Eigen::Matrix3Xd& points_S_m) {
  if (ct.size.minCoeff() < 4 || ct.values.size() != ct.num_voxels()) {
    throw Error("a cubic interpolant needs at least 4 voxels along each axis and a value for every voxel", ct.source,
                "give a volume of at least 4 x 4 x 4 voxels");
  }
  const CubicInterpolant interpolant(ToItkImage(ct));
  CtSamples samples;
  samples.values_hu = Eigen::VectorXd::Constant(points_S_m.cols(), std::numeric_limits<double>::quiet_NaN());
  samples.gradients_hu_per_m = Eigen::Matrix3Xd::Constant(3, points_S_m.cols(), std::numeric_limits<double>::quiet_NaN());
  samples.inside.assign(points_S_m.cols(), false);
  for (Eigen::Index i = 0; i < points_S_m.cols(); ++i) {
    double value;
    Eigen::Vector3d gradient_per_mm;
    if (!interpolant.Evaluate(points_S_m.col(i) * kMmPerM, &value, &gradient_per_mm)) continue;
    samples.values_hu[i] = value;
    samples.gradients_hu_per_m.col(i) = gradient_per_mm * kMmPerM;
    samples.inside[i] = true;
  }
  return samples;
}

std::vector<double> NodeDisplacementArray(const std::vector<PhaseDeformation>& deformations,
                                          const Eigen::Matrix3Xd& nodes_S_m) {
  std::vector<double> array;
  array.reserve(deformations.size() * nodes_S_m.size());
  for (const PhaseDeformation& deformation : deformations) {
    const Eigen::Matrix3Xd u = deformation.Displacements(nodes_S_m);
    array.insert(array.end(), u.data(), u.data() + u.size());  // column-major 3xN is row-major [N, 3]
  }
  return array;
}

}  // namespace dg::stages::preop
