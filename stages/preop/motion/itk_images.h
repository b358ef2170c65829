#pragma once

// The ITK types the motion registration works with, the CT as ITK images, and
// the B-spline's domain over them.
// For this library's sources only: it brings ITK's headers.

// ITK 5.2 brings its own Eigen 3.3 and includes its Eigenvalues module under
// the same include guards: the project's Eigen 3.4 must be complete first, or
// 3.3's modules compile against 3.4's Core.
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <itkBSplineTransform.h>
#include <itkImage.h>

#include "io/ct/ct_image.h"

namespace dg::stages::preop::registration {

// ITK works here in millimetres (the CT's own unit) so that the optimiser's
// tolerances and the B-spline coefficients are O(1) numbers.
constexpr double kMmPerM = 1000.0;
constexpr unsigned kDim = 3;
constexpr unsigned kSplineOrder = 3;

using Image = itk::Image<float, kDim>;
using BSpline = itk::BSplineTransform<double, kDim, kSplineOrder>;

// The grid of `ct` as an ITK image without voxels: a geometry.
Image::Pointer DomainOf(const io::CtImage& ct);

// The voxels of `ct` on `grid`, a box of ct's own grid (RegistrationGrid).
Image::Pointer ToItkImage(const io::CtImage& ct, const io::CtImage& grid);
// All of ct's voxels.
Image::Pointer ToItkImage(const io::CtImage& ct);

// transform as the identity over `domain`'s extent (half a voxel beyond its
// outer voxels' centres, and an eighth of a voxel more, as ITK's
// BSplineTransformInitializer), with mesh's intervals along `domain`'s own
// axes. ITK's initializer turns the grid's axes towards the physical ones;
// along the image's, a sample grid of the image's (GridMeanSquares) has the
// control grid's axes whatever the image's direction.
void SetDomain(const Image::Pointer& domain, const BSpline::MeshSizeType& mesh, BSpline* transform);

}  // namespace dg::stages::preop::registration
