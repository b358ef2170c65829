#include "stages/preop/segment/surface_extraction.h"

#include <algorithm>
#include <string>

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <vtkCellArray.h>
#include <vtkFlyingEdges3D.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkQuadricDecimation.h>
#include <vtkSmartPointer.h>
#include <vtkWindowedSincPolyDataFilter.h>

#include "sim/error.h"

namespace dg::stages::preop {
namespace {

// The mask as a float image in voxel-index coordinates (spacing 1), padded by
// one empty voxel so that point (i, j, k) of the output is voxel (i, j, k).
vtkSmartPointer<vtkImageData> PaddedImage(const VoxelMask& mask) {
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(mask.size.x() + 2, mask.size.y() + 2, mask.size.z() + 2);
  image->SetOrigin(-1, -1, -1);
  image->SetSpacing(1, 1, 1);
  image->AllocateScalars(VTK_FLOAT, 1);
  float* values = static_cast<float*>(image->GetScalarPointer());
  std::fill(values, values + (mask.size.array() + 2).prod(), 0.0f);
  for (int k = 0; k < mask.size.z(); ++k) {
    for (int j = 0; j < mask.size.y(); ++j) {
      for (int i = 0; i < mask.size.x(); ++i) {
        values[(i + 1) + (mask.size.x() + 2) * ((j + 1) + (mask.size.y() + 2) * (k + 1))] =
            mask.inside[mask.Index(i, j, k)];
      }
    }
  }
  return image;
}

io::SurfaceMesh ToSurfaceMesh(vtkPolyData* poly, const VoxelMask& mask) {
  io::SurfaceMesh surface;
  surface.vertices_m.resize(3, poly->GetNumberOfPoints());
  for (vtkIdType p = 0; p < poly->GetNumberOfPoints(); ++p) {
    double ijk[3];
    poly->GetPoint(p, ijk);
    surface.vertices_m.col(p) = mask.PointOf(ijk[0], ijk[1], ijk[2]);
  }
  vtkCellArray* polys = poly->GetPolys();
  surface.triangles.resize(3, polys->GetNumberOfCells());
  vtkIdType n = 0;
  const vtkIdType* ids = nullptr;
  int t = 0;
  for (polys->InitTraversal(); polys->GetNextCell(n, ids); ++t) {
    DG_CHECK(n == 3);  // flying edges and quadric decimation make triangles only
    for (int c = 0; c < 3; ++c) surface.triangles(c, t) = static_cast<int>(ids[c]);
  }
  return surface;
}

}  // namespace

std::string SurfaceOptions::Validate() const {
  if (smoothing_iterations < 0) return fmt::format("smoothing_iterations must be >= 0, got {}", smoothing_iterations);
  if (!(smoothing_pass_band > 0 && smoothing_pass_band <= 2)) {
    return fmt::format("smoothing_pass_band must lie in (0, 2], got {:g}", smoothing_pass_band);
  }
  if (target_triangles < 4) return fmt::format("target_triangles must be >= 4, got {}", target_triangles);
  return "";
}

double SixEnclosedVolume(const io::SurfaceMesh& surface) {
  double six_volume = 0;
  for (int t = 0; t < surface.num_triangles(); ++t) {
    const auto& v = surface.vertices_m;
    const auto& f = surface.triangles;
    six_volume += v.col(f(0, t)).dot(v.col(f(1, t)).cross(v.col(f(2, t))));
  }
  return six_volume;
}

io::SurfaceMesh ExtractSurface(const VoxelMask& mask, const SurfaceOptions& options, SurfaceReport* report) {
  if (std::string problem = options.Validate(); !problem.empty()) {
    throw Error("invalid surface options: " + problem, "surface extraction", "correct the option");
  }
  if (mask.Count() == 0) {
    throw Error("the mask is empty: there is no surface to extract", "surface extraction",
                "check the segmentation that made the mask");
  }

  vtkNew<vtkFlyingEdges3D> flying_edges;
  flying_edges->SetInputData(PaddedImage(mask));
  flying_edges->SetValue(0, 0.5);
  flying_edges->ComputeNormalsOff();
  flying_edges->ComputeGradientsOff();
  flying_edges->ComputeScalarsOff();
  flying_edges->Update();
  const vtkIdType extracted = flying_edges->GetOutput()->GetNumberOfPolys();

  vtkNew<vtkWindowedSincPolyDataFilter> smoother;
  smoother->SetInputConnection(flying_edges->GetOutputPort());
  smoother->SetNumberOfIterations(options.smoothing_iterations);
  smoother->SetPassBand(options.smoothing_pass_band);
  smoother->NormalizeCoordinatesOn();  // the pass band's scale does not depend on the grid's size
  smoother->FeatureEdgeSmoothingOff();
  smoother->BoundarySmoothingOff();
  smoother->NonManifoldSmoothingOn();

  vtkNew<vtkQuadricDecimation> decimation;
  decimation->SetInputConnection(smoother->GetOutputPort());
  decimation->SetTargetReduction(std::max(0.0, 1.0 - static_cast<double>(options.target_triangles) / extracted));
  decimation->VolumePreservationOn();
  decimation->Update();

  io::SurfaceMesh surface = ToSurfaceMesh(decimation->GetOutput(), mask);
  // Flying edges winds its triangles by the image's axes; a mirroring
  // direction (determinant -1) turns them inside out.
  double six_volume = SixEnclosedVolume(surface);
  if (six_volume < 0) {
    surface.triangles.row(1).swap(surface.triangles.row(2));
    six_volume = -six_volume;
  }
  if (report) *report = {static_cast<int>(extracted), surface.num_triangles(), six_volume / 6};
  return surface;
}

}  // namespace dg::stages::preop
