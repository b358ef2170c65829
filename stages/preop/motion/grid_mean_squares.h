#pragma once

#include <itkSingleValuedCostFunction.h>

#include "stages/preop/motion/itk_images.h"

namespace dg::stages::preop::registration {

// The mean squared HU difference between the fixed image's samples and the
// moving image through the B-spline, with its gradient over the spline's
// coefficients. The samples are a grid whose axes are the control grid's
// (both are phase 0's), so a sample's B-spline weights are the product of one
// row of 4 weights per axis, found once per level. The displacement at every
// sample is then three passes of 4-term sums, one axis at a time (about 12
// multiply-adds per sample and coordinate, where a sample's own 4^3 support
// costs 64), and the gradient over the coefficients is the transpose of those
// passes. ITK's own mean-squares metrics form the dense 3 x P Jacobian of the
// transform at every sample instead. The moving image is a cubic B-spline
// interpolant, so value and gradient agree and the line searches see a smooth
// function. One evaluation at a time: the passes' arrays are kept between
// evaluations, as an optimiser calls them in turn.
//
// @pre transform's control grid is set, with fixed_samples' axes (both phase
//      0's); transform must outlive the result. Its value and gradient are
//      over transform's parameters (mm), plus bending_weight times the
//      control points' mean squared second difference.
itk::SingleValuedCostFunction::Pointer MakeGridMeanSquares(const Image::Pointer& fixed_samples,
                                                           const Image::Pointer& moving, BSpline* transform,
                                                           double bending_weight);

}  // namespace dg::stages::preop::registration
