#include "stages/preop/motion/itk_images.h"

#include <algorithm>

namespace dg::stages::preop::registration {

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

void SetDomain(const Image::Pointer& domain, const BSpline::MeshSizeType& mesh, BSpline* transform) {
  constexpr double kBeyond_voxels = 0.5 + 0.125;
  itk::ContinuousIndex<double, kDim> corner;
  BSpline::PhysicalDimensionsType extent;
  for (unsigned d = 0; d < kDim; ++d) {
    corner[d] = double(domain->GetLargestPossibleRegion().GetIndex(d)) - kBeyond_voxels;
    extent[d] = (double(domain->GetLargestPossibleRegion().GetSize(d)) - 1 + 2 * kBeyond_voxels) * domain->GetSpacing()[d];
  }
  Image::PointType origin;
  domain->TransformContinuousIndexToPhysicalPoint(corner, origin);
  transform->SetTransformDomainOrigin(origin);
  transform->SetTransformDomainPhysicalDimensions(extent);
  transform->SetTransformDomainDirection(domain->GetDirection());
  transform->SetTransformDomainMeshSize(mesh);
  transform->SetIdentity();
}

}  // namespace dg::stages::preop::registration
