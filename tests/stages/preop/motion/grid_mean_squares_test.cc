#include "stages/preop/motion/grid_mean_squares.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <itkImageRegionConstIteratorWithIndex.h>
#include <itkImageRegionIteratorWithIndex.h>

#include "stages/preop/motion/cubic_interpolant.h"

namespace dg::stages::preop::registration {
namespace {

// An image on an oblique grid (rotated about two axes), valued by f (mm).
template <typename F>
Image::Pointer ObliqueImage(const Image::SizeType& size, const Image::SpacingType& spacing,
                            const Image::PointType& origin, F f) {
  const Eigen::Matrix3d rotation =
      (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  Image::DirectionType direction;
  for (unsigned d = 0; d < kDim; ++d)
    for (unsigned e = 0; e < kDim; ++e) direction(d, e) = rotation(d, e);
  const Image::Pointer image = Image::New();
  image->SetRegions(size);
  image->SetSpacing(spacing);
  image->SetOrigin(origin);
  image->SetDirection(direction);
  image->Allocate();
  for (itk::ImageRegionIteratorWithIndex<Image> it(image, image->GetBufferedRegion()); !it.IsAtEnd(); ++it) {
    Image::PointType x;
    image->TransformIndexToPhysicalPoint(it.GetIndex(), x);
    it.Set(static_cast<float>(f(Eigen::Vector3d(x[0], x[1], x[2]))));
  }
  return image;
}

double Fixed(const Eigen::Vector3d& x) { return 300 * std::sin(x.x() / 7) * std::cos(x.y() / 9) + 2 * x.z(); }
double Moving(const Eigen::Vector3d& x) { return 300 * std::sin(x.x() / 6.5 + 0.2) * std::cos(x.y() / 9.5) + 2.1 * x.z(); }

// The separable passes against the definition: at every sample of a grid
// coarser than the spline's domain and offset from it, ITK's transform
// moves the sample and the moving image's interpolant is compared with the
// fixed value there; the mean of the squared differences over the samples
// inside is the metric. Its gradient is checked against central differences
// of its value.
TEST_CASE("grid mean squares: the mean over ITK's transformed samples, and its gradient", "[unit]") {
  Image::SizeType size{{24, 20, 18}};
  Image::SpacingType spacing;
  spacing[0] = 1.5, spacing[1] = 2, spacing[2] = 2.5;
  Image::PointType origin;
  origin[0] = -10, origin[1] = 5, origin[2] = 3;
  const Image::Pointer domain = ObliqueImage(size, spacing, origin, Fixed);
  const Image::Pointer moving = ObliqueImage(size, spacing, origin, Moving);
  // Every second voxel along x and y and every voxel along z, from voxel (1, 1, 0).
  Image::SizeType sample_size{{11, 9, 18}};
  Image::SpacingType sample_spacing = spacing;
  sample_spacing[0] *= 2, sample_spacing[1] *= 2;
  Image::IndexType one{{1, 1, 0}};
  Image::PointType sample_origin;
  domain->TransformIndexToPhysicalPoint(one, sample_origin);
  const Image::Pointer samples = ObliqueImage(sample_size, sample_spacing, sample_origin, Fixed);

  const BSpline::Pointer transform = BSpline::New();
  BSpline::MeshSizeType mesh;
  mesh[0] = 3, mesh[1] = 2, mesh[2] = 4;
  SetDomain(domain, mesh, transform.GetPointer());
  BSpline::ParametersType parameters(transform->GetNumberOfParameters());
  std::mt19937 random(7);
  std::uniform_real_distribution<double> within(-1.5, 1.5);
  for (unsigned p = 0; p < parameters.Size(); ++p) parameters[p] = within(random);
  transform->SetParametersByValue(parameters);

  const auto metric = MakeGridMeanSquares(samples, moving, transform.GetPointer(), /*bending_weight=*/0);

  const CubicInterpolant interpolant(moving);
  double sum = 0;
  int count = 0;
  for (itk::ImageRegionConstIteratorWithIndex<Image> it(samples, samples->GetBufferedRegion()); !it.IsAtEnd(); ++it) {
    Image::PointType X;
    samples->TransformIndexToPhysicalPoint(it.GetIndex(), X);
    BSpline::WeightsType weights(transform->GetNumberOfWeights());
    BSpline::ParameterIndexArrayType indices(transform->GetNumberOfWeights());
    BSpline::OutputPointType x;
    bool inside = false;
    transform->TransformPoint(X, x, weights, indices, inside);
    double value;
    Eigen::Vector3d gradient;
    if (!inside || !interpolant.Evaluate(Eigen::Vector3d(x[0], x[1], x[2]), &value, &gradient)) continue;
    sum += std::pow(value - it.Get(), 2);
    ++count;
  }
  REQUIRE(count > 1000);
  const double value = metric->GetValue(parameters);
  CHECK(std::abs(value - sum / count) <= 1e-9 * value);

  itk::SingleValuedCostFunction::DerivativeType derivative;
  metric->GetDerivative(parameters, derivative);
  double worst = 0;
  for (unsigned p = 0; p < parameters.Size(); p += 7) {
    constexpr double kStep_mm = 1e-4;
    BSpline::ParametersType plus = parameters, minus = parameters;
    plus[p] += kStep_mm, minus[p] -= kStep_mm;
    const double difference = (metric->GetValue(plus) - metric->GetValue(minus)) / (2 * kStep_mm);
    worst = std::max(worst, std::abs(difference - derivative[p]) / (1e-3 + derivative.inf_norm()));
  }
  INFO("worst gradient error, relative to the largest component: " << worst);
  CHECK(worst < 5e-9);  // 5e-10 here; central differences of step 1e-4 mm round at about 1e-9
}

}  // namespace
}  // namespace dg::stages::preop::registration
