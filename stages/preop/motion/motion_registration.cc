#include "stages/preop/motion/motion_registration.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <sstream>
#include <vector>

// ITK 5.2 brings its own Eigen 3.3 and includes its Eigenvalues module under
// the same include guards: the project's Eigen 3.4 (our header included its
// Core) must be complete first, or 3.3's modules compile against 3.4's Core.
#include <Eigen/Eigenvalues>
#include <ceres/gradient_problem.h>
#include <ceres/gradient_problem_solver.h>
#include <itkBSplineDecompositionImageFilter.h>
#include <itkBSplineTransform.h>
#include <itkBSplineTransformInitializer.h>
#include <itkBSplineTransformParametersAdaptor.h>
#include <itkDisplacementFieldJacobianDeterminantFilter.h>
#include <itkImage.h>
#include <itkImageRegionConstIteratorWithIndex.h>
#include <itkImageRegionIteratorWithIndex.h>
#include <itkLinearInterpolateImageFunction.h>
#include <itkMattesMutualInformationImageToImageMetric.h>
#include <itkMeanSquaresImageToImageMetric.h>
#include <itkMinimumMaximumImageCalculator.h>
#include <itkSingleValuedCostFunction.h>
#include <itkRecursiveGaussianImageFilter.h>
#include <itkTransformToDisplacementFieldFilter.h>

#include "sim/cubic_bspline.h"
#include "sim/error.h"

namespace dg::stages::preop {
namespace {

// ITK works here in millimetres (the CT's own unit) so that the optimiser's
// tolerances and the B-spline coefficients are O(1) numbers.
constexpr double kMmPerM = 1000.0;
constexpr unsigned kDim = 3;
constexpr unsigned kSplineOrder = 3;

using Image = itk::Image<float, kDim>;
using BSpline = itk::BSplineTransform<double, kDim, kSplineOrder>;
using VectorImage = itk::Image<itk::Vector<float, kDim>, kDim>;

// The voxels of `ct` on `grid`, a box of ct's own grid (RegistrationGrid).
Image::Pointer DomainOf(const io::CtImage& ct);

Image::Pointer ToItkImage(const io::CtImage& ct, const io::CtImage& grid) {
  Image::Pointer image = DomainOf(grid);
  image->Allocate();
  const Eigen::Vector3i first =
      ((ct.direction * ct.spacing_m.asDiagonal()).inverse() * (grid.origin_m - ct.origin_m)).array().round().cast<int>();
  float* out = image->GetBufferPointer();
  for (int k = 0; k < grid.size.z(); ++k)
    for (int j = 0; j < grid.size.y(); ++j) {
      const float* row = &ct.values[ct.Index(first.x(), first.y() + j, first.z() + k)];
      out = std::copy(row, row + grid.size.x(), out);
    }
  return image;
}
Image::Pointer ToItkImage(const io::CtImage& ct) { return ToItkImage(ct, ct); }

// The grid of `ct` as an ITK image without voxels: a geometry.
Image::Pointer DomainOf(const io::CtImage& ct) {
  Image::RegionType region;
  Image::SpacingType spacing;
  Image::PointType origin;
  Image::DirectionType direction;
  for (unsigned d = 0; d < kDim; ++d) {
    region.SetSize(d, ct.size[d]);
    spacing[d] = ct.spacing_m[d] * kMmPerM;
    origin[d] = ct.origin_m[d] * kMmPerM;
    for (unsigned e = 0; e < kDim; ++e) direction(d, e) = ct.direction(d, e);
  }
  Image::Pointer image = Image::New();
  image->SetRegions(region);
  image->SetSpacing(spacing);
  image->SetOrigin(origin);
  image->SetDirection(direction);
  return image;
}

// Index i mirrored into [0, n - 1] about the end samples (ITK's boundary
// condition for B-spline interpolation). @pre -(n - 1) <= i <= 2 (n - 1).
long Mirrored(long i, long n) {
  if (i < 0) return -i;
  if (i > n - 1) return 2 * (n - 1) - i;
  return i;
}

// The moving image as a cubic B-spline interpolant (ITK's prefilter makes the
// coefficients, so the function is ITK's BSplineInterpolateImageFunction's;
// at least 4 voxels along each axis, so that the support mirrors in range),
// evaluated with its gradient by a plain tensor-product loop: ITK's evaluator
// recomputes its weight tables through generic containers at every call, and
// took 40% of a registration.
class CubicInterpolant {
 public:
  explicit CubicInterpolant(const Image::Pointer& image) {
    using Decomposition = itk::BSplineDecompositionImageFilter<Image, itk::Image<double, kDim>>;
    const Decomposition::Pointer decomposition = Decomposition::New();
    decomposition->SetSplineOrder(3);
    decomposition->SetInput(image);
    decomposition->SetNumberOfWorkUnits(1);
    decomposition->Update();
    const auto& coefficients = decomposition->GetOutput();
    coefficients_.assign(coefficients->GetBufferPointer(),
                         coefficients->GetBufferPointer() + coefficients->GetBufferedRegion().GetNumberOfPixels());
    Eigen::Matrix3d direction, spacing = Eigen::Matrix3d::Zero();
    for (unsigned d = 0; d < kDim; ++d) {
      size_[d] = static_cast<long>(image->GetBufferedRegion().GetSize(d));
      origin_[d] = image->GetOrigin()[d];
      spacing(d, d) = image->GetSpacing()[d];
      for (unsigned e = 0; e < kDim; ++e) direction(d, e) = image->GetDirection()(d, e);
    }
    to_index_ = (direction * spacing).inverse();
    gradient_to_physical_ = direction * spacing.inverse();
  }

  // Value and physical gradient at the physical point x; false where x is
  // more than half a voxel beyond the outer voxels' centres (ITK's
  // IsInsideBuffer), where the moving image is not compared.
  bool Evaluate(const Eigen::Vector3d& x, double* value, Eigen::Vector3d* gradient) const {
    const Eigen::Vector3d index = to_index_ * (x - origin_);
    long first[kDim];
    double w[kDim][4], dw[kDim][4];
    for (unsigned d = 0; d < kDim; ++d) {
      if (!(index[d] >= -0.5 && index[d] < size_[d] - 0.5)) return false;
      const double floor = std::floor(index[d]);
      first[d] = static_cast<long>(floor) - 1;
      sim::CubicBSplineWeights(index[d] - floor, w[d]);
      sim::CubicBSplineDerivativeWeights(index[d] - floor, dw[d]);
    }
    double sum = 0;
    Eigen::Vector3d along_index = Eigen::Vector3d::Zero();
    for (int c = 0; c < 4; ++c) {
      const long k = Mirrored(first[2] + c, size_[2]);
      for (int b = 0; b < 4; ++b) {
        const long j = Mirrored(first[1] + b, size_[1]);
        const double* row = &coefficients_[size_[0] * (j + size_[1] * k)];
        double v = 0, dv = 0;
        for (int a = 0; a < 4; ++a) {
          const double coefficient = row[Mirrored(first[0] + a, size_[0])];
          v += w[0][a] * coefficient;
          dv += dw[0][a] * coefficient;
        }
        sum += w[2][c] * w[1][b] * v;
        along_index[0] += w[2][c] * w[1][b] * dv;
        along_index[1] += w[2][c] * dw[1][b] * v;
        along_index[2] += dw[2][c] * w[1][b] * v;
      }
    }
    *value = sum;
    *gradient = gradient_to_physical_ * along_index;
    return true;
  }

 private:
  std::vector<double> coefficients_;
  long size_[kDim];
  Eigen::Vector3d origin_;
  Eigen::Matrix3d to_index_, gradient_to_physical_;
};

// The mean squared HU difference between the fixed image's voxels and the
// moving image through the B-spline, with its gradient over the spline's
// coefficients. ITK's own mean-squares metrics (both generations) form the
// dense 3 x P Jacobian of the transform at every sample, O(P) per sample; a
// sample only moves with the 4^3 control points around it, and this visits
// only those (as ITK's Mattes metric does for mutual information). A sample's
// control points and their weights depend on its fixed position only, so
// they are found once per level (checked against ITK's transform), and each
// evaluation is two tensor-product loops. The moving image is a cubic
// B-spline interpolant, so value and gradient agree and the line searches see
// a smooth function.
class SparseMeanSquares final : public itk::SingleValuedCostFunction {
 public:
  using Self = SparseMeanSquares;
  using Pointer = itk::SmartPointer<Self>;
  itkNewMacro(Self);

  // @pre transform's grid is set; it must outlive this cost function.
  void Initialize(const Image::Pointer& fixed, const Image::Pointer& moving, BSpline* transform,
                  double bending_weight) {
    transform_ = transform;
    bending_weight_ = bending_weight;
    moving_ = std::make_unique<CubicInterpolant>(moving);
    const BSpline::ImagePointer grid = transform->GetCoefficientImages()[0];
    for (unsigned d = 0; d < kDim; ++d) {
      grid_size_[d] = static_cast<long>(grid->GetBufferedRegion().GetSize(d));
      grid_origin_[d] = grid->GetOrigin()[d];
      for (unsigned e = 0; e < kDim; ++e) grid_axes_(d, e) = grid->GetDirection()(d, e) * grid->GetSpacing()[e];
    }
    samples_.clear();
    BSpline::WeightsType itk_weights(transform->GetNumberOfWeights());
    BSpline::ParameterIndexArrayType itk_indices(transform->GetNumberOfWeights());
    for (itk::ImageRegionConstIteratorWithIndex<Image> it(fixed, fixed->GetBufferedRegion()); !it.IsAtEnd(); ++it) {
      Image::PointType X;
      fixed->TransformIndexToPhysicalPoint(it.GetIndex(), X);
      BSpline::OutputPointType unused;
      bool inside = false;
      transform->TransformPoint(X, unused, itk_weights, itk_indices, inside);
      if (!inside) continue;  // outside the spline's domain: no motion defined there, not compared
      Sample sample;
      sample.fixed_value = it.Get();
      // The support starts where ITK's transform starts it: at a sample on a
      // knot, rounding may put it one interval either side, where the extra
      // weight is zero either way.
      itk::ContinuousIndex<double, kDim> at;
      grid->TransformPhysicalPointToContinuousIndex(X, at);
      sample.first = static_cast<std::int32_t>(itk_indices[0]);
      const Eigen::Matrix<long, 3, 1> first = FirstPerAxis(sample);
      for (unsigned d = 0; d < kDim; ++d) sample.t[d] = at[d] - double(first[d] + 1);
      CheckAgainstItk(sample, X, itk_weights, itk_indices);
      samples_.push_back(sample);
    }
  }

  unsigned int GetNumberOfParameters() const override { return transform_->GetNumberOfParameters(); }

  MeasureType GetValue(const ParametersType& parameters) const override {
    return Evaluate(parameters, nullptr);
  }
  void GetDerivative(const ParametersType& parameters, DerivativeType& derivative) const override {
    Evaluate(parameters, &derivative);
  }
  void GetValueAndDerivative(const ParametersType& parameters, MeasureType& value,
                             DerivativeType& derivative) const override {
    value = Evaluate(parameters, &derivative);
  }

 private:
  // A fixed voxel as the spline sees it, in 32 bytes (a CT of 10^8 voxels
  // must fit twice in memory): its position and weights follow from these.
  struct Sample {
    double t[kDim];           // position within its knot interval along each axis, [0, 1]
    std::int32_t first = 0;   // linear index of its first control point (per-axis coefficient grid)
    float fixed_value = 0;
  };

  Eigen::Matrix<long, 3, 1> FirstPerAxis(const Sample& sample) const {
    return {sample.first % grid_size_[0], (sample.first / grid_size_[0]) % grid_size_[1],
            sample.first / (grid_size_[0] * grid_size_[1])};
  }
  // The sample's position, mm: the grid's continuous index first + 1 + t.
  Eigen::Vector3d FixedPosition(const Sample& sample) const {
    const Eigen::Vector3d at = (FirstPerAxis(sample).array() + 1).cast<double>().matrix() +
                               Eigen::Vector3d(sample.t[0], sample.t[1], sample.t[2]);
    return grid_origin_ + grid_axes_ * at;
  }
  static void Weights(const Sample& sample, double weights[kDim][4]) {
    for (unsigned d = 0; d < kDim; ++d) sim::CubicBSplineWeights(sample.t[d], weights[d]);
  }

  // The sample's control points, weights and position must be those ITK's
  // transform uses (the same grid convention), or the motion would not be
  // the spline's.
  void CheckAgainstItk(const Sample& sample, const Image::PointType& X, const BSpline::WeightsType& itk_weights,
                       const BSpline::ParameterIndexArrayType& indices) const {
    double weights[kDim][4];
    Weights(sample, weights);
    bool same = (FixedPosition(sample) - Eigen::Vector3d(X[0], X[1], X[2])).norm() < 1e-9;
    unsigned w = 0;
    for (int c = 0; c < 4; ++c) {
      for (int b = 0; b < 4; ++b) {
        for (int a = 0; a < 4; ++a, ++w) {
          const long index = sample.first + a + grid_size_[0] * (b + grid_size_[1] * c);
          const double weight = weights[0][a] * weights[1][b] * weights[2][c];
          same = same && index == long(indices[w]) && std::abs(weight - itk_weights[w]) <= 1e-9;
        }
      }
    }
    if (!same) itkExceptionMacro("the B-spline grid's convention differs from ITK's transform at a fixed sample");
  }

  double Evaluate(const ParametersType& parameters, DerivativeType* derivative) const {
    const unsigned per_axis = transform_->GetNumberOfParametersPerDimension();
    if (derivative) {
      derivative->SetSize(transform_->GetNumberOfParameters());
      derivative->Fill(0.0);
    }
    const double* p = parameters.data_block();
    const long row = grid_size_[0], slab = grid_size_[0] * grid_size_[1];
    double sum = 0;
    size_t count = 0;
    double weights[kDim][4];
    for (const Sample& sample : samples_) {
      Weights(sample, weights);
      Eigen::Vector3d x = FixedPosition(sample);
      for (int c = 0; c < 4; ++c) {
        for (int b = 0; b < 4; ++b) {
          const double wbc = weights[1][b] * weights[2][c];
          const long base = sample.first + row * b + slab * c;
          for (unsigned d = 0; d < kDim; ++d) {
            const double* q = p + d * per_axis + base;
            x[d] += wbc * (weights[0][0] * q[0] + weights[0][1] * q[1] + weights[0][2] * q[2] + weights[0][3] * q[3]);
          }
        }
      }
      double value;
      Eigen::Vector3d gradient;
      if (!moving_->Evaluate(x, &value, &gradient)) continue;  // no overlap there: not compared
      const double difference = value - sample.fixed_value;
      sum += difference * difference;
      ++count;
      if (!derivative) continue;
      const Eigen::Vector3d scaled = 2 * difference * gradient;
      double* g = derivative->data_block();
      for (int c = 0; c < 4; ++c) {
        for (int b = 0; b < 4; ++b) {
          const double wbc = weights[1][b] * weights[2][c];
          const long base = sample.first + row * b + slab * c;
          for (int a = 0; a < 4; ++a) {
            const double weight = wbc * weights[0][a];
            for (unsigned d = 0; d < kDim; ++d) g[d * per_axis + base + a] += weight * scaled[d];
          }
        }
      }
    }
    if (count == 0) itkExceptionMacro("no fixed sample maps inside the moving image");
    if (derivative) *derivative /= double(count);
    return sum / double(count) + Bending(parameters, derivative);
  }

  // bending_weight times the mean squared second difference of the control
  // points' displacements along each grid axis (a discrete bending energy):
  // zero for an affine motion, it gives curvature to the directions the
  // images leave free (a uniform interior, sliding along a smooth surface),
  // where quasi-Newton steps would otherwise follow the noise.
  double Bending(const ParametersType& parameters, DerivativeType* derivative) const {
    if (bending_weight_ <= 0) return 0;
    const auto size = transform_->GetCoefficientImages()[0]->GetLargestPossibleRegion().GetSize();
    const unsigned per_axis = transform_->GetNumberOfParametersPerDimension();
    const long stride[kDim] = {1, long(size[0]), long(size[0] * size[1])};
    double sum = 0;
    size_t terms = 0;
    std::vector<double> gradient(derivative ? parameters.Size() : 0, 0.0);
    for (unsigned a = 0; a < kDim; ++a) {
      for (unsigned k = 0; k < size[2]; ++k) {
        for (unsigned j = 0; j < size[1]; ++j) {
          for (unsigned i = 0; i < size[0]; ++i) {
            const unsigned along = a == 0 ? i : a == 1 ? j : k;
            if (along == 0 || along + 1 == size[a]) continue;
            const long centre = long(i) + stride[1] * j + stride[2] * k;
            for (unsigned d = 0; d < kDim; ++d) {
              const long c = centre + long(d * per_axis);
              const double r = parameters[c - stride[a]] - 2 * parameters[c] + parameters[c + stride[a]];
              sum += r * r;
              ++terms;
              if (derivative) {
                gradient[c - stride[a]] += 2 * r;
                gradient[c] -= 4 * r;
                gradient[c + stride[a]] += 2 * r;
              }
            }
          }
        }
      }
    }
    if (terms == 0) return 0;
    const double scale = bending_weight_ / double(terms);
    if (derivative) {
      for (size_t p = 0; p < gradient.size(); ++p) (*derivative)[p] += scale * gradient[p];
    }
    return scale * sum;
  }

  BSpline* transform_ = nullptr;
  double bending_weight_ = 0;
  std::unique_ptr<CubicInterpolant> moving_;
  long grid_size_[kDim] = {0, 0, 0};  // control points per axis
  Eigen::Vector3d grid_origin_ = Eigen::Vector3d::Zero();      // control point 0, mm
  Eigen::Matrix3d grid_axes_ = Eigen::Matrix3d::Identity();    // columns: a step along each grid axis, mm
  std::vector<Sample> samples_;
};

// The metric between fixed (every voxel a sample) and moving through
// transform, on one thread.
itk::SingleValuedCostFunction::Pointer MakeMetric(MotionMetric kind, const Image::Pointer& fixed,
                                                  const Image::Pointer& moving, const BSpline::Pointer& transform,
                                                  double bending_weight) {
  if (kind == MotionMetric::kMeanSquares) {
    const SparseMeanSquares::Pointer metric = SparseMeanSquares::New();
    metric->Initialize(fixed, moving, transform, bending_weight);
    return metric.GetPointer();
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

// Smoothed by half a sampling factor along each axis, so that the samples
// taken at that factor do not alias (none along an axis sampled fully).
Image::Pointer Smoothed(Image::Pointer image, const Factors& factors) {
  for (unsigned d = 0; d < kDim; ++d) {
    if (factors[d] == 1) continue;
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
  return image;
}

// Every factor-th voxel along each axis, each sample placed at the voxel it
// copies (the samples centred on the image to within half a voxel; where
// ITK's filter places them right, the same samples). Not ITK's
// ShrinkImageFilter: that centres its output grid on the input's and copies
// the voxel nearest each output point, so along an axis of 2m voxels (and of
// 4m + 2 at factor 4) every sample lies half a voxel from the voxel it holds,
// and the fixed image of each shrunk level is shifted by half a voxel along
// that axis (1.5 mm on a 3 mm CT), which the finest level only partly undoes.
Image::Pointer Shrunk(const Image::Pointer& image, const Factors& factors) {
  if (*std::max_element(factors.begin(), factors.end()) == 1) return image;
  const Image::RegionType& region = image->GetBufferedRegion();
  Image::RegionType shrunk_region;
  Image::IndexType first;
  Image::SpacingType spacing = image->GetSpacing();
  for (unsigned d = 0; d < kDim; ++d) {
    const long factor = factors[d];
    const long voxels = static_cast<long>(region.GetSize(d));
    const long samples = std::max(1L, voxels / factor);  // as many as ITK's filter takes
    first[d] = region.GetIndex(d) + (voxels - 1 - (samples - 1) * factor) / 2;
    shrunk_region.SetSize(d, samples);
    spacing[d] *= factor;
  }
  Image::PointType origin;
  image->TransformIndexToPhysicalPoint(first, origin);
  const Image::Pointer shrunk = Image::New();
  shrunk->SetRegions(shrunk_region);
  shrunk->SetSpacing(spacing);
  shrunk->SetOrigin(origin);
  shrunk->SetDirection(image->GetDirection());
  shrunk->Allocate();
  for (itk::ImageRegionIteratorWithIndex<Image> it(shrunk, shrunk_region); !it.IsAtEnd(); ++it) {
    Image::IndexType source;
    for (unsigned d = 0; d < kDim; ++d) source[d] = first[d] + long(factors[d]) * it.GetIndex()[d];
    it.Set(image->GetPixel(source));
  }
  return shrunk;
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
// against images smoothed by half the sampling factors (so the sampled fixed
// grid does not alias) and the fixed image's voxels sampled at those factors.
void RunLevel(const Image::Pointer& fixed, const Image::Pointer& moving, const BSpline::Pointer& transform,
              const Factors& factors, const MotionRegistrationOptions& options, PhaseRegistrationReport* report) {
  const itk::SingleValuedCostFunction::Pointer metric =
      MakeMetric(options.metric, Shrunk(Smoothed(fixed, factors), factors), Smoothed(moving, factors), transform,
                 options.bending_weight);
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
}

// The spline's domain is `domain`'s extent (phase 0's whole grid, no
// voxels), whatever part of it the images cover: its control points are
// then where a registration of the whole grid puts them, whatever the
// region. Control points with no sample near them keep the identity.
BSpline::Pointer FitSpline(const Image::Pointer& fixed, const Image::Pointer& moving, const Image::Pointer& domain,
                           const MotionRegistrationOptions& options, PhaseRegistrationReport* report) {
  const BSpline::Pointer transform = BSpline::New();
  for (int level = 0; level < options.levels; ++level) {
    const unsigned shrink = 1u << (options.levels - 1 - level);
    const BSpline::MeshSizeType mesh = MeshSize(domain, options.grid_spacing_mm * shrink);
    if (level == 0) {
      using Initializer = itk::BSplineTransformInitializer<BSpline, Image>;
      const Initializer::Pointer initializer = Initializer::New();
      initializer->SetTransform(transform);
      initializer->SetImage(domain);
      initializer->SetTransformDomainMeshSize(mesh);
      initializer->InitializeTransform();
      transform->SetIdentity();
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
    RunLevel(fixed, moving, transform, Times(FinestFactors(fixed, options), shrink), options, report);
  }
  return transform;
}

}  // namespace

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

// The spline (in millimetres) and the grid it is defined over.
struct PhaseDeformation::Spline {
  BSpline::Pointer transform;
  io::CtImage grid;  // phase 0's geometry, no values
};

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

PhaseDeformation RegisterPhase(const std::vector<io::CtImage>& phases, int k, const MotionRegistrationOptions& options) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw Error(problem, "MotionRegistrationOptions", "set the option in range");
  }
  CheckPhases(phases);
  if (k < 1 || k >= static_cast<int>(phases.size())) {
    throw Error("phase " + std::to_string(k) + " is not one of phases 1 to " + std::to_string(phases.size() - 1),
                "motion registration", "register each phase after the first to the first");
  }
  const auto start = std::chrono::steady_clock::now();
  PhaseRegistrationReport report;
  report.phase = k;
  // Each call its own copies: ITK's pipeline writes into its inputs'
  // requested regions, so images are not shared between registrations.
  auto spline = std::make_shared<PhaseDeformation::Spline>();
  spline->grid = RegistrationGrid(phases[0], options);
  const Image::Pointer fixed = ToItkImage(phases[0], spline->grid);
  const Image::Pointer moving = ToItkImage(phases[k], spline->grid);
  try {
    spline->transform = FitSpline(fixed, moving, DomainOf(phases[0]), options, &report);
    const BSpline::ParametersType result = spline->transform->GetParameters();
    const BSpline::ParametersType identity(result.Size(), 0.0);
    const Factors finest = FinestFactors(fixed, options);
    const Image::Pointer fixed_samples = Shrunk(Smoothed(fixed, finest), finest);
    const auto metric =
        MakeMetric(options.metric, fixed_samples, Smoothed(moving, finest), spline->transform, /*bending_weight=*/0);
    report.metric_before = metric->GetValue(identity);
    report.metric_after = metric->GetValue(result);
    spline->transform->SetParametersByValue(result);
    std::tie(report.min_jacobian, report.max_jacobian) = JacobianRange(spline->transform, fixed_samples);
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("ITK failed to register the phase: ") + e.GetDescription(),
                "phase " + std::to_string(k) + " (" + phases[k].source + ")",
                "check that the phase shows the same anatomy as phase 0 on the same grid");
  }
  report.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return PhaseDeformation(std::move(spline), report);
}

std::vector<PhaseDeformation> RegisterPhases(const std::vector<io::CtImage>& phases,
                                             const MotionRegistrationOptions& options) {
  CheckPhases(phases);
  std::vector<PhaseDeformation> deformations(phases.size());
  for (int k = 1; k < static_cast<int>(phases.size()); ++k) deformations[k] = RegisterPhase(phases, k, options);
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
