#include "stages/preop/motion/cubic_interpolant.h"

#include <cmath>

#include <itkBSplineDecompositionImageFilter.h>

#include "sim/cubic_bspline.h"

namespace dg::stages::preop::registration {
namespace {

// Index i mirrored into [0, n - 1] about the end samples (ITK's boundary
// condition for B-spline interpolation). @pre -(n - 1) <= i <= 2 (n - 1).
long Mirrored(long i, long n) {
  if (i < 0) return -i;
  if (i > n - 1) return 2 * (n - 1) - i;
  return i;
}

}  // namespace

CubicInterpolant::CubicInterpolant(const Image::Pointer& image) {
  // Coefficients in float (the filter works in double): the voxels' own
  // precision, and half the memory and bandwidth of the samples' lookups.
  using Decomposition = itk::BSplineDecompositionImageFilter<Image, Image>;
  const Decomposition::Pointer decomposition = Decomposition::New();
  decomposition->SetSplineOrder(3);
  decomposition->SetInput(image);
  decomposition->SetNumberOfWorkUnits(1);
  decomposition->Update();
  coefficients_ = decomposition->GetOutput();
  coefficients_->DisconnectPipeline();
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

bool CubicInterpolant::Evaluate(const Eigen::Vector3d& x, double* value, Eigen::Vector3d* gradient) const {
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
  // Away from the border (nearly every sample), the support's indices need
  // no mirroring.
  bool interior = true;
  for (unsigned d = 0; d < kDim; ++d) interior = interior && first[d] >= 0 && first[d] + 3 < size_[d];
  long along_x[4];
  for (int a = 0; a < 4; ++a) along_x[a] = interior ? first[0] + a : Mirrored(first[0] + a, size_[0]);
  double sum = 0;
  Eigen::Vector3d along_index = Eigen::Vector3d::Zero();
  for (int c = 0; c < 4; ++c) {
    const long k = interior ? first[2] + c : Mirrored(first[2] + c, size_[2]);
    for (int b = 0; b < 4; ++b) {
      const long j = interior ? first[1] + b : Mirrored(first[1] + b, size_[1]);
      const float* row = coefficients_->GetBufferPointer() + size_[0] * (j + size_[1] * k);
      double v = 0, dv = 0;
      for (int a = 0; a < 4; ++a) {
        const double coefficient = row[along_x[a]];
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

}  // namespace dg::stages::preop::registration
