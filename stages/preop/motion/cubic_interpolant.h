#pragma once

#include "stages/preop/motion/itk_images.h"

namespace dg::stages::preop::registration {

// The moving image as a cubic B-spline interpolant (ITK's prefilter makes the
// coefficients, so the function is ITK's BSplineInterpolateImageFunction's;
// at least 4 voxels along each axis, so that the support mirrors in range),
// evaluated with its gradient by a plain tensor-product loop: ITK's evaluator
// recomputes its weight tables through generic containers at every call, and
// took 40% of a registration.
class CubicInterpolant {
 public:
  explicit CubicInterpolant(const Image::Pointer& image);

  // Value and physical gradient at the physical point x (mm); false where x
  // is more than half a voxel beyond the outer voxels' centres (ITK's
  // IsInsideBuffer), where the moving image is not compared.
  bool Evaluate(const Eigen::Vector3d& x, double* value, Eigen::Vector3d* gradient) const;

 private:
  Image::Pointer coefficients_;  // kept as ITK made them: a copy would add to a fine scan's peak
  long size_[kDim];
  Eigen::Vector3d origin_;
  Eigen::Matrix3d to_index_, gradient_to_physical_;
};

}  // namespace dg::stages::preop::registration
