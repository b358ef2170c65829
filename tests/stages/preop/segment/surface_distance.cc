#include "tests/stages/preop/segment/surface_distance.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <vtkCellArray.h>
#include <vtkGenericCell.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkStaticCellLocator.h>

namespace dg::testing {

Eigen::Matrix3Xd SampleSurface(const io::SurfaceMesh& surface, double spacing_m) {
  std::vector<Eigen::Vector3d> points;
  for (int t = 0; t < surface.num_triangles(); ++t) {
    const Eigen::Vector3d p0 = surface.vertices_m.col(surface.triangles(0, t));
    const Eigen::Vector3d p1 = surface.vertices_m.col(surface.triangles(1, t));
    const Eigen::Vector3d p2 = surface.vertices_m.col(surface.triangles(2, t));
    const double longest = std::max({(p1 - p0).norm(), (p2 - p1).norm(), (p0 - p2).norm()});
    const int n = std::max(1, static_cast<int>(std::ceil(longest / spacing_m)));
    for (int i = 0; i <= n; ++i) {
      for (int j = 0; i + j <= n; ++j) points.push_back(p0 + (p1 - p0) * i / n + (p2 - p0) * j / n);
    }
  }
  Eigen::Matrix3Xd samples(3, static_cast<Eigen::Index>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i) samples.col(static_cast<Eigen::Index>(i)) = points[i];
  return samples;
}

std::vector<double> DistancesTo(const Eigen::Matrix3Xd& points, const io::SurfaceMesh& surface) {
  vtkNew<vtkPoints> vertices;
  for (int v = 0; v < surface.num_vertices(); ++v) vertices->InsertNextPoint(surface.vertices_m.col(v).data());
  vtkNew<vtkCellArray> triangles;
  for (int t = 0; t < surface.num_triangles(); ++t) {
    const vtkIdType ids[3] = {surface.triangles(0, t), surface.triangles(1, t), surface.triangles(2, t)};
    triangles->InsertNextCell(3, ids);
  }
  vtkNew<vtkPolyData> poly;
  poly->SetPoints(vertices);
  poly->SetPolys(triangles);
  vtkNew<vtkStaticCellLocator> locator;
  locator->SetDataSet(poly);
  locator->BuildLocator();
  vtkNew<vtkGenericCell> cell;
  std::vector<double> distances(points.cols());
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    const Eigen::Vector3d x = points.col(i);
    double closest[3], squared = 0;
    vtkIdType cell_id = 0;
    int sub_id = 0;
    locator->FindClosestPoint(x.data(), closest, cell, cell_id, sub_id, squared);
    distances[i] = std::sqrt(squared);
  }
  return distances;
}

DistanceSummary Summarise(const std::vector<double>& distances) {
  if (distances.empty()) return {};
  return {std::accumulate(distances.begin(), distances.end(), 0.0) / distances.size(),
          *std::max_element(distances.begin(), distances.end())};
}

}  // namespace dg::testing
