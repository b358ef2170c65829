#pragma once

#include <vector>

#include <Eigen/Core>

#include "io/surface_mesh.h"

namespace dg::testing {

// Points spread over every triangle of `surface` (a barycentric grid), at most
// spacing_m apart along each triangle's edges, vertices included.
Eigen::Matrix3Xd SampleSurface(const io::SurfaceMesh& surface, double spacing_m);

// The distance from each point to the nearest point of `surface` (on a
// triangle, not just a vertex), through VTK's cell locator: independent of
// the code under test.
std::vector<double> DistancesTo(const Eigen::Matrix3Xd& points, const io::SurfaceMesh& surface);

struct DistanceSummary {
  double mean_m = 0;
  double max_m = 0;
};
DistanceSummary Summarise(const std::vector<double>& distances);

// Symmetric figures between two surfaces: the mean of all distances both ways,
// and the Hausdorff distance (the larger of the two one-way maxima). Each
// surface's points are kept only where `keep` (a point in S) is true.
template <class Keep>
DistanceSummary SymmetricDistance(const io::SurfaceMesh& a, const io::SurfaceMesh& b, double spacing_m, Keep keep) {
  std::vector<double> all;
  for (auto [from, to] : {std::pair{&a, &b}, std::pair{&b, &a}}) {
    const Eigen::Matrix3Xd samples = SampleSurface(*from, spacing_m);
    Eigen::Matrix3Xd kept(3, samples.cols());
    Eigen::Index n = 0;
    for (Eigen::Index i = 0; i < samples.cols(); ++i) {
      if (keep(Eigen::Vector3d(samples.col(i)))) kept.col(n++) = samples.col(i);
    }
    const std::vector<double> d = DistancesTo(kept.leftCols(n), *to);
    all.insert(all.end(), d.begin(), d.end());
  }
  return Summarise(all);
}

}  // namespace dg::testing
