#include "stages/preop/motion/grid_mean_squares.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "sim/cubic_bspline.h"
#include "stages/preop/motion/cubic_interpolant.h"

namespace dg::stages::preop::registration {
namespace {

// See MakeGridMeanSquares.
class GridMeanSquares final : public itk::SingleValuedCostFunction {
 public:
  using Self = GridMeanSquares;
  using Pointer = itk::SmartPointer<Self>;
  itkNewMacro(Self);

  // @pre transform's grid is set, with fixed's direction; transform must
  //      outlive this cost function.
  void Initialize(const Image::Pointer& fixed, const Image::Pointer& moving, BSpline* transform,
                  double bending_weight) {
    transform_ = transform;
    bending_weight_ = bending_weight;
    moving_ = std::make_unique<CubicInterpolant>(moving);
    const BSpline::ImagePointer grid = transform->GetCoefficientImages()[0];
    for (unsigned d = 0; d < kDim; ++d) {
      for (unsigned e = 0; e < kDim; ++e) {
        if (std::abs(fixed->GetDirection()(d, e) - grid->GetDirection()(d, e)) > 1e-9) {
          itkExceptionMacro("the fixed samples' axes differ from the B-spline grid's");
        }
      }
    }
    Image::IndexType origin_index;
    origin_index.Fill(0);
    Image::PointType origin;
    fixed->TransformIndexToPhysicalPoint(origin_index, origin);
    itk::ContinuousIndex<double, kDim> at_origin;
    grid->TransformPhysicalPointToContinuousIndex(origin, at_origin);
    for (unsigned d = 0; d < kDim; ++d) {
      controls_[d] = static_cast<long>(grid->GetBufferedRegion().GetSize(d));
      const long samples = static_cast<long>(fixed->GetBufferedRegion().GetSize(d));
      const double step = fixed->GetSpacing()[d] / grid->GetSpacing()[d];  // grid index per sample, along d
      axes_[d].resize(samples);
      for (long i = 0; i < samples; ++i) {
        AxisWeights& axis = axes_[d][i];
        const double at = at_origin[d] + step * double(i);
        const double floor = std::floor(at);
        axis.first = static_cast<long>(floor) - 1;
        axis.inside = axis.first >= 0 && axis.first + 3 < controls_[d];
        sim::CubicBSplineWeights(at - floor, axis.weights);
      }
      origin_[d] = origin[d];
      for (unsigned e = 0; e < kDim; ++e) to_physical_(d, e) = fixed->GetDirection()(d, e) * fixed->GetSpacing()[e];
    }
    fixed_values_.assign(fixed->GetBufferPointer(),
                         fixed->GetBufferPointer() + fixed->GetBufferedRegion().GetNumberOfPixels());
    field_.assign(kDim * fixed_values_.size(), 0.0);
    CheckAgainstItk();
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
  // A sample's B-spline weights along one axis.
  struct AxisWeights {
    long first = 0;        // its first control point along the axis
    double weights[4];     // of that control point and the next three
    bool inside = false;   // all four on the grid: the motion is defined there
  };

  long Samples(unsigned d) const { return static_cast<long>(axes_[d].size()); }

  // One axis of the spline, for `outer` blocks: along the axis, sample s
  // takes the four control planes from axis[s].first, each plane `inner`
  // values long (1 along x, a row along y, a slice along z). Forward, the
  // samples gather w times the control planes; transposed, the control
  // planes gather w times the samples (the gradient's pass).
  static void AlongAxis(const std::vector<AxisWeights>& axis, long controls, long outer, long inner,
                        bool transposed, const double* from, double* to) {
    const long samples = static_cast<long>(axis.size());
    for (long o = 0; o < outer; ++o) {
      for (long s = 0; s < samples; ++s) {
        const AxisWeights& w = axis[s];
        if (!w.inside) continue;
        for (int t = 0; t < 4; ++t) {
          const long control = (o * controls + w.first + t) * inner, sample = (o * samples + s) * inner;
          const double* in = from + (transposed ? sample : control);
          double* out = to + (transposed ? control : sample);
          for (long v = 0; v < inner; ++v) out[v] += w.weights[t] * in[v];
        }
      }
    }
  }

  // Coordinate d of the displacement (mm) at every sample, into
  // field_[d * samples ...], from that coordinate's control points p: along
  // x into [cz][cy][x], along y into [cz][y][x], along z into [z][y][x].
  void Displacements(const double* p, unsigned d) const {
    const long nx = Samples(0), ny = Samples(1), nz = Samples(2);
    const long cx = controls_[0], cy = controls_[1], cz = controls_[2];
    scratch_[0].assign(cz * cy * nx, 0.0);
    AlongAxis(axes_[0], cx, cz * cy, 1, false, p, scratch_[0].data());
    scratch_[1].assign(cz * ny * nx, 0.0);
    AlongAxis(axes_[1], cy, cz, nx, false, scratch_[0].data(), scratch_[1].data());
    double* field = &field_[d * nx * ny * nz];
    std::fill(field, field + nx * ny * nz, 0.0);
    AlongAxis(axes_[2], cz, 1, ny * nx, false, scratch_[1].data(), field);
  }

  // The transpose of Displacements: g (coordinate d's control points) gets
  // the sum over samples of field_[d * samples ...] times each control
  // point's weight there.
  void AddTransposed(unsigned d, double* g) const {
    const long nx = Samples(0), ny = Samples(1), nz = Samples(2);
    const long cx = controls_[0], cy = controls_[1], cz = controls_[2];
    scratch_[1].assign(cz * ny * nx, 0.0);
    AlongAxis(axes_[2], cz, 1, ny * nx, true, &field_[d * nx * ny * nz], scratch_[1].data());
    scratch_[0].assign(cz * cy * nx, 0.0);
    AlongAxis(axes_[1], cy, cz, nx, true, scratch_[1].data(), scratch_[0].data());
    AlongAxis(axes_[0], cx, cz * cy, 1, true, scratch_[0].data(), g);
  }

  // The separable passes must give ITK's transform, or the motion fitted
  // would not be the spline's: checked at the grid's corners and a spread of
  // samples, with the transform's parameters as the level starts (the
  // coarser level's result refined).
  void CheckAgainstItk() const {
    const BSpline::ParametersType& parameters = transform_->GetParameters();
    const unsigned per_axis = transform_->GetNumberOfParametersPerDimension();
    for (unsigned d = 0; d < kDim; ++d) Displacements(parameters.data_block() + d * per_axis, d);
    const long n = static_cast<long>(fixed_values_.size());
    for (long v = 0; v < n; v += std::max(1L, n / 997)) CheckSample(v);
    CheckSample(n - 1);
  }
  void CheckSample(long v) const {
    const long nx = Samples(0), ny = Samples(1), n = static_cast<long>(fixed_values_.size());
    const long i = v % nx, j = (v / nx) % ny, k = v / (nx * ny);
    if (!(axes_[0][i].inside && axes_[1][j].inside && axes_[2][k].inside)) return;
    const Eigen::Vector3d X = origin_ + to_physical_ * Eigen::Vector3d(double(i), double(j), double(k));
    BSpline::InputPointType point;
    for (unsigned d = 0; d < kDim; ++d) point[d] = X[d];
    const BSpline::OutputPointType x = transform_->TransformPoint(point);
    for (unsigned d = 0; d < kDim; ++d) {
      if (std::abs(x[d] - X[d] - field_[d * n + v]) > 1e-9 * (1 + std::abs(x[d] - X[d]))) {
        itkExceptionMacro("the B-spline grid's convention differs from ITK's transform at a fixed sample");
      }
    }
  }

  double Evaluate(const ParametersType& parameters, DerivativeType* derivative) const {
    const unsigned per_axis = transform_->GetNumberOfParametersPerDimension();
    const double* p = parameters.data_block();
    for (unsigned d = 0; d < kDim; ++d) Displacements(p + d * per_axis, d);
    const long nx = Samples(0), ny = Samples(1), nz = Samples(2), n = nx * ny * nz;
    double sum = 0;
    size_t count = 0;
    long v = 0;
    for (long k = 0; k < nz; ++k) {
      for (long j = 0; j < ny; ++j) {
        for (long i = 0; i < nx; ++i, ++v) {
          Eigen::Vector3d x(field_[v], field_[n + v], field_[2 * n + v]);
          for (unsigned d = 0; d < kDim; ++d) field_[d * n + v] = 0;  // from here on, the metric's gradient at the sample
          if (!(axes_[0][i].inside && axes_[1][j].inside && axes_[2][k].inside)) continue;  // no motion defined there
          x += origin_ + to_physical_ * Eigen::Vector3d(double(i), double(j), double(k));
          double value;
          Eigen::Vector3d gradient;
          if (!moving_->Evaluate(x, &value, &gradient)) continue;  // no overlap there: not compared
          const double difference = value - fixed_values_[v];
          sum += difference * difference;
          ++count;
          for (unsigned d = 0; d < kDim; ++d) field_[d * n + v] = 2 * difference * gradient[d];
        }
      }
    }
    if (count == 0) itkExceptionMacro("no fixed sample maps inside the moving image");
    if (derivative) {
      derivative->SetSize(transform_->GetNumberOfParameters());
      derivative->Fill(0.0);
      for (unsigned d = 0; d < kDim; ++d) AddTransposed(d, derivative->data_block() + d * per_axis);
      *derivative /= double(count);
    }
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
  long controls_[kDim] = {0, 0, 0};            // control points per axis
  std::vector<AxisWeights> axes_[kDim];        // per sample index along each axis
  Eigen::Vector3d origin_;                     // sample (0, 0, 0), mm
  Eigen::Matrix3d to_physical_;                // sample index to mm
  std::vector<float> fixed_values_;            // x fastest
  mutable std::vector<double> field_;          // per coordinate, per sample: the displacement, then the gradient
  mutable std::vector<double> scratch_[2];     // the passes along x and y
};

}  // namespace

itk::SingleValuedCostFunction::Pointer MakeGridMeanSquares(const Image::Pointer& fixed_samples,
                                                           const Image::Pointer& moving, BSpline* transform,
                                                           double bending_weight) {
  const GridMeanSquares::Pointer metric = GridMeanSquares::New();
  metric->Initialize(fixed_samples, moving, transform, bending_weight);
  return metric.GetPointer();
}

}  // namespace dg::stages::preop::registration
