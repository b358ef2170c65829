#include "sim/embedding.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include <Eigen/Dense>
#include <tbb/parallel_for.h>

#include "sim/error.h"

namespace dg::sim {
namespace {

using Box = Eigen::AlignedBox3d;

// A uniform grid of cells over a box; each cell lists the items whose bounding
// boxes overlap it (compressed rows). About two items per cell on average.
class CellGrid {
 public:
  CellGrid(const Box& bounds, const std::vector<Box>& item_boxes) {
    const Eigen::Vector3d extent = bounds.sizes().cwiseMax(1e-12);
    const double cells_wanted = std::max(1.0, item_boxes.size() / 2.0);
    cell_m_ = std::cbrt(extent.prod() / cells_wanted);
    origin_ = bounds.min();
    for (int i = 0; i < 3; ++i) dims_[i] = std::clamp(static_cast<int>(std::ceil(extent[i] / cell_m_)), 1, 256);
    std::vector<int> counts(NumCells() + 1, 0);
    ForEachCell(item_boxes, [&](int, int cell) { ++counts[cell + 1]; });
    for (int c = 0; c < NumCells(); ++c) counts[c + 1] += counts[c];
    offsets_ = counts;
    items_.resize(offsets_.back());
    ForEachCell(item_boxes, [&](int item, int cell) { items_[counts[cell]++] = item; });
  }

  double cell_m() const { return cell_m_; }
  // The cell holding a point, clamped to the grid.
  Eigen::Vector3i CellOf(const Eigen::Vector3d& p) const {
    Eigen::Vector3i c;
    for (int i = 0; i < 3; ++i) {
      const double f = std::floor((p[i] - origin_[i]) / cell_m_);
      c[i] = static_cast<int>(std::clamp(f, 0.0, double(dims_[i] - 1)));
    }
    return c;
  }
  // Calls visit(item) for every item of the cells at Chebyshev distance exactly ring from centre.
  template <typename Visit>
  void VisitRing(const Eigen::Vector3i& centre, int ring, Visit visit) const {
    const Eigen::Vector3i lo = (centre.array() - ring).max(0).matrix();
    const Eigen::Vector3i hi = (centre.array() + ring).min(dims_.array() - 1).matrix();
    for (int z = lo.z(); z <= hi.z(); ++z) {
      for (int y = lo.y(); y <= hi.y(); ++y) {
        for (int x = lo.x(); x <= hi.x(); ++x) {
          const int chebyshev = (Eigen::Vector3i(x, y, z) - centre).cwiseAbs().maxCoeff();
          if (chebyshev != ring) continue;
          const int cell = Index(x, y, z);
          for (int k = offsets_[cell]; k < offsets_[cell + 1]; ++k) visit(items_[k]);
        }
      }
    }
  }
  // The largest ring that still holds a cell of the grid.
  int MaxRing() const { return dims_.maxCoeff(); }

 private:
  int NumCells() const { return dims_.prod(); }
  int Index(int x, int y, int z) const { return x + dims_.x() * (y + dims_.y() * z); }
  template <typename Visit>
  void ForEachCell(const std::vector<Box>& boxes, Visit visit) const {
    for (int item = 0; item < static_cast<int>(boxes.size()); ++item) {
      const Eigen::Vector3i lo = CellOf(boxes[item].min()), hi = CellOf(boxes[item].max());
      for (int z = lo.z(); z <= hi.z(); ++z) {
        for (int y = lo.y(); y <= hi.y(); ++y) {
          for (int x = lo.x(); x <= hi.x(); ++x) visit(item, Index(x, y, z));
        }
      }
    }
  }

  double cell_m_ = 1;
  Eigen::Vector3d origin_;
  Eigen::Vector3i dims_;
  std::vector<int> offsets_, items_;
};

// Barycentric coordinates of p in element e: solves
// [X1-X0 X2-X0 X3-X0] (w1 w2 w3)^T = p - X0, w0 = 1 - w1 - w2 - w3.
Eigen::Vector4d Barycentric(const TetMesh& mesh, int e, const Eigen::Vector3d& p) {
  const Eigen::Vector3d x0 = mesh.X_m.col(mesh.tets(0, e));
  Eigen::Matrix3d edges;
  for (int k = 0; k < 3; ++k) edges.col(k) = mesh.X_m.col(mesh.tets(k + 1, e)) - x0;
  const Eigen::Vector3d w = edges.inverse() * (p - x0);
  return {1 - w.sum(), w[0], w[1], w[2]};
}

// The point of triangle abc nearest to p (Ericson, Real-Time Collision Detection, 5.1.5).
Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double denominator = 1 / (va + vb + vc);
  return a + ab * (vb * denominator) + ac * (vc * denominator);
}

// The element each boundary face belongs to: the one element holding all three of its nodes.
std::vector<int> FaceOwners(const TetMesh& mesh, const Eigen::Matrix3Xi& faces) {
  const NodeIncidence incidence = BuildNodeIncidence(mesh);
  std::vector<int> owners(faces.cols(), -1);
  for (Eigen::Index f = 0; f < faces.cols(); ++f) {
    const int a = faces(0, f);
    for (int k = incidence.offsets[a]; k < incidence.offsets[a + 1] && owners[f] < 0; ++k) {
      const int e = incidence.elements[k];
      const auto holds = [&](int node) { return (mesh.tets.col(e).array() == node).any(); };
      if (holds(faces(1, f)) && holds(faces(2, f))) owners[f] = e;
    }
    DG_CHECK(owners[f] >= 0);
  }
  return owners;
}

// Accepts a point on an element's face or edge as inside it despite round-off.
constexpr double kInsideTolerance = 1e-10;

}  // namespace

Embedding::Embedding(const TetMesh& mesh, const Eigen::Matrix3Xd& points_m) : num_nodes_(mesh.num_nodes()) {
  const std::string where = "sim::Embedding (mesh " + mesh.source + ")";
  if (mesh.num_tets() == 0) throw Error("the mesh has no elements", where, "embed in a tetrahedral mesh");
  for (Eigen::Index p = 0; p < points_m.cols(); ++p) {
    if (!points_m.col(p).allFinite())
      throw Error("point " + std::to_string(p) + " is not finite", where, "check the overlay mesh's vertices");
  }

  Box bounds;
  std::vector<Box> tet_boxes(mesh.num_tets());
  for (int e = 0; e < mesh.num_tets(); ++e) {
    for (int k = 0; k < 4; ++k) tet_boxes[e].extend(mesh.X_m.col(mesh.tets(k, e)));
    bounds.extend(tet_boxes[e]);
  }
  const CellGrid tet_grid(bounds, tet_boxes);
  const Eigen::Matrix3Xi faces = BoundaryFaces(mesh);
  const std::vector<int> owners = FaceOwners(mesh, faces);
  std::vector<Box> face_boxes(faces.cols());
  for (Eigen::Index f = 0; f < faces.cols(); ++f) {
    for (int k = 0; k < 3; ++k) face_boxes[f].extend(mesh.X_m.col(faces(k, f)));
  }
  const CellGrid face_grid(bounds, face_boxes);

  const Eigen::Index count = points_m.cols();
  node_ids_.resize(4, count);
  weights_.resize(4, count);
  elements_.resize(count);
  std::vector<double> outside_distance(count, 0.0);
  tbb::parallel_for(Eigen::Index(0), count, [&](Eigen::Index p) {
    const Eigen::Vector3d point = points_m.col(p);
    // Inside: among the elements of the point's cell, the one it is deepest in
    // (a point on a shared face belongs to either; this picks one deterministically).
    int best = -1;
    double best_min_weight = 0;
    Eigen::Vector4d best_weights;
    tet_grid.VisitRing(tet_grid.CellOf(point), 0, [&](int e) {
      const Eigen::Vector4d w = Barycentric(mesh, e, point);
      const double min_weight = w.minCoeff();
      if (min_weight < -kInsideTolerance) return;
      if (best < 0 || min_weight > best_min_weight || (min_weight == best_min_weight && e < best)) {
        best = e;
        best_min_weight = min_weight;
        best_weights = w;
      }
    });
    if (best < 0) {
      // Outside: the owner of the nearest boundary face, searched ring by ring
      // until no unvisited cell can be nearer than the best face so far (a cell
      // in ring r is at least (r - 1) cells from the point's own).
      double best_distance = std::numeric_limits<double>::infinity();
      const Eigen::Vector3i centre = face_grid.CellOf(point);
      for (int ring = 0; ring <= face_grid.MaxRing(); ++ring) {
        face_grid.VisitRing(centre, ring, [&](int f) {
          const double d = (point - ClosestPointOnTriangle(point, mesh.X_m.col(faces(0, f)), mesh.X_m.col(faces(1, f)),
                                                           mesh.X_m.col(faces(2, f))))
                               .norm();
          if (d < best_distance || (d == best_distance && owners[f] < best)) {
            best_distance = d;
            best = owners[f];
          }
        });
        if (best >= 0 && best_distance <= ring * face_grid.cell_m()) break;
      }
      DG_CHECK(best >= 0);
      best_weights = Barycentric(mesh, best, point);
      outside_distance[p] = best_distance;
    }
    elements_[p] = best;
    node_ids_.col(p) = mesh.tets.col(best);
    weights_.col(p) = best_weights;
  });
  for (const double d : outside_distance) {
    if (d > 0) {
      ++num_outside_;
      max_outside_distance_m_ = std::max(max_outside_distance_m_, d);
    }
  }
}

void Embedding::Rebuild(const Eigen::Matrix3Xd& nodes_m, Eigen::Matrix3Xd* positions) const {
  DG_CHECK(nodes_m.cols() == num_nodes_);
  const Eigen::Index count = weights_.cols();
  positions->resize(3, count);
  constexpr Eigen::Index kBlock = 4096;
  tbb::parallel_for(Eigen::Index(0), (count + kBlock - 1) / kBlock, [&](Eigen::Index block) {
    const Eigen::Index end = std::min(count, (block + 1) * kBlock);
    const int* ids = node_ids_.data();
    const double* w = weights_.data();
    const double* x = nodes_m.data();
    double* out = positions->data();
    // Plain loops over columns: the compiler turns the four gathers per point into vector gathers.
    for (Eigen::Index p = block * kBlock; p < end; ++p) {
      for (int i = 0; i < 3; ++i) {
        out[3 * p + i] = w[4 * p] * x[3 * ids[4 * p] + i] + w[4 * p + 1] * x[3 * ids[4 * p + 1] + i] +
                         w[4 * p + 2] * x[3 * ids[4 * p + 2] + i] + w[4 * p + 3] * x[3 * ids[4 * p + 3] + i];
      }
    }
  });
}

Eigen::Matrix3Xd Embedding::Rebuild(const Eigen::Matrix3Xd& nodes_m) const {
  Eigen::Matrix3Xd positions;
  Rebuild(nodes_m, &positions);
  return positions;
}

std::string Embedding::Describe() const {
  char text[160];
  std::snprintf(text, sizeof text, "%d points embedded, %d outside the mesh (farthest %.3f mm)", num_points(),
                num_outside_, max_outside_distance_m_ * 1e3);
  return text;
}

}  // namespace dg::sim
