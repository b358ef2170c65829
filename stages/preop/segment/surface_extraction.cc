#include "stages/preop/segment/surface_extraction.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <vtkCellArray.h>
#include <vtkDecimatePro.h>
#include <vtkFlyingEdges3D.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataAlgorithm.h>
#include <vtkPolyDataConnectivityFilter.h>
#include <vtkQuadricDecimation.h>
#include <vtkSmartPointer.h>
#include <vtkWindowedSincPolyDataFilter.h>

#include "sim/error.h"
#include "sim/log.h"

namespace dg::stages::preop {
namespace {

constexpr const char* kWhere = "surface extraction";

// A Gaussian blur of standard deviation sigma along one axis of a dense
// volume (x fastest), truncated at three sigma; values beyond the volume are 0.
void BlurAlong(int axis, double sigma, const Eigen::Vector3i& size, std::vector<float>* values) {
  const int radius = static_cast<int>(std::ceil(3 * sigma));
  std::vector<double> weights(2 * radius + 1);
  for (int d = -radius; d <= radius; ++d) weights[d + radius] = std::exp(-0.5 * d * d / (sigma * sigma));
  const double total = std::accumulate(weights.begin(), weights.end(), 0.0);
  for (double& w : weights) w /= total;
  const std::size_t stride = axis == 0 ? 1 : axis == 1 ? size.x() : static_cast<std::size_t>(size.x()) * size.y();
  const int n = size[axis];
  std::vector<float> line(n);
  const std::vector<float> in = *values;
  for (std::size_t start = 0; start < in.size(); ++start) {
    if ((start / stride) % n != 0) continue;  // not the first voxel of a line along the axis
    for (int i = 0; i < n; ++i) {
      double sum = 0;
      for (int d = std::max(-radius, -i); d <= std::min(radius, n - 1 - i); ++d) {
        sum += weights[d + radius] * in[start + (i + d) * stride];
      }
      (*values)[start + i * stride] = static_cast<float>(sum);
    }
  }
}

// The grid flying edges works on: the mask's voxels averaged in blocks of
// factors voxels, each holding the fraction of its voxels inside (factors 1:
// the mask's voxels themselves). It spans the mask's whole grid, not the
// box of its inside voxels: on voxels of their own (the phantom's, a 3 mm
// CT's) the points then come out exactly as flying edges makes them on the
// grid, which Gmsh's exact predicates tell apart from a box's to the last
// bit (docs/preop.md, "Tetrahedralisation").
struct ExtractionImage {
  Eigen::Vector3i size = Eigen::Vector3i::Zero();
  Eigen::Vector3i factors = Eigen::Vector3i::Ones();
  std::vector<float> fraction;  // x fastest
  std::size_t voxels_inside = 0;
  VoxelMask grid;  // the mask's grid (PointOf), no voxels
};

// Triangles flying edges may make per triangle kept: the decimation then
// removes the voxels' staircase without the cost of millions of triangles.
constexpr double kExtractedPerKept = 20;

// The block size along each axis: about one triangle of flying edges per
// half square of side h, so a surface of area A gives about 2 A / h^2
// triangles; h is chosen for kExtractedPerKept times the target, and never
// below the voxels (the phantom's 1 mm heart keeps its voxels; a 0.6 mm scan
// of a liver is taken in blocks of 2 x 2 x 1).
Eigen::Vector3i BlockFactors(const VoxelMask& mask, int target_triangles) {
  const Eigen::Vector3d spacing_mm = 1e3 * mask.spacing_m;
  double area_mm2 = 0;  // of the voxels' faces between inside and outside: the staircase's area
  for (int k = 0; k < mask.size.z(); ++k)
    for (int j = 0; j < mask.size.y(); ++j)
      for (int i = 0; i < mask.size.x(); ++i) {
        const bool in = mask.inside[mask.Index(i, j, k)];
        const Eigen::Vector3i v(i, j, k);
        for (int axis = 0; axis < 3; ++axis) {
          const Eigen::Vector3i next = v + Eigen::Vector3i::Unit(axis);
          const bool next_in = next[axis] < mask.size[axis] && mask.inside[mask.Index(next.x(), next.y(), next.z())];
          const int faces = (in != next_in) + (in && v[axis] == 0);  // the low edge of the grid as well
          area_mm2 += faces * spacing_mm.prod() / spacing_mm[axis];
        }
      }
  const double h_mm = std::sqrt(2 * area_mm2 / (kExtractedPerKept * target_triangles));
  return (h_mm / spacing_mm.array()).floor().cast<int>().max(1);
}

ExtractionImage BlockFractions(const VoxelMask& mask, const Eigen::Vector3i& factors) {
  ExtractionImage image;
  image.factors = factors;
  image.size = (mask.size + factors - Eigen::Vector3i::Ones()).array() / factors.array();
  image.fraction.assign(static_cast<std::size_t>(image.size.x()) * image.size.y() * image.size.z(), 0.0f);
  const float weight = 1.0f / static_cast<float>(factors.prod());  // voxels beyond the grid count as outside
  for (int k = 0; k < mask.size.z(); ++k)
    for (int j = 0; j < mask.size.y(); ++j)
      for (int i = 0; i < mask.size.x(); ++i) {
        if (!mask.inside[mask.Index(i, j, k)]) continue;
        ++image.voxels_inside;
        const Eigen::Vector3i b = Eigen::Vector3i(i, j, k).array() / factors.array();
        image.fraction[b.x() + image.size.x() * (static_cast<std::size_t>(b.y()) + static_cast<std::size_t>(image.size.y()) * b.z())] += weight;
      }
  image.grid.size = mask.size;
  image.grid.spacing_m = mask.spacing_m;
  image.grid.origin_m = mask.origin_m;
  image.grid.direction = mask.direction;
  return image;
}

// The blocks as VTK's image, padded by `pad` empty blocks and blurred along
// each axis by sigma_blocks (0: not at all), placed in the mask's voxel
// indices (a block at its voxels' centre): VTK's image has no direction, so
// its points are voxel indices, mapped to S by the mask's grid. On blocks of
// one voxel every point then comes out as from the whole grid, to the bit,
// and one scan on grids whose origins differ in the last digit meshes alike.
vtkSmartPointer<vtkImageData> PaddedImage(const ExtractionImage& in, int pad, const Eigen::Vector3d& sigma_blocks) {
  const Eigen::Vector3i padded = in.size.array() + 2 * pad;
  std::vector<float> values(padded.cast<std::size_t>().prod(), 0.0f);
  for (int k = 0; k < in.size.z(); ++k) {
    for (int j = 0; j < in.size.y(); ++j) {
      for (int i = 0; i < in.size.x(); ++i) {
        values[(i + pad) + padded.x() * (static_cast<std::size_t>(j + pad) + padded.y() * (k + pad))] =
            in.fraction[i + in.size.x() * (static_cast<std::size_t>(j) + static_cast<std::size_t>(in.size.y()) * k)];
      }
    }
  }
  for (int axis = 0; axis < 3; ++axis) {
    if (sigma_blocks[axis] > 0) BlurAlong(axis, sigma_blocks[axis], padded, &values);
  }
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(padded.x(), padded.y(), padded.z());
  double origin[3], spacing[3];
  for (int d = 0; d < 3; ++d) {
    spacing[d] = in.factors[d];
    origin[d] = 0.5 * (in.factors[d] - 1) - pad * spacing[d];
  }
  image->SetOrigin(origin);
  image->SetSpacing(spacing);
  image->AllocateScalars(VTK_FLOAT, 1);
  std::copy(values.begin(), values.end(), static_cast<float*>(image->GetScalarPointer()));
  return image;
}

// The polygons' used points mapped to S, renumbered in order of first use.
io::SurfaceMesh ToSurfaceMesh(vtkPolyData* poly, const ExtractionImage& blocks) {
  vtkCellArray* polys = poly->GetPolys();
  io::SurfaceMesh surface;
  surface.triangles.resize(3, polys->GetNumberOfCells());
  std::vector<int> new_id(poly->GetNumberOfPoints(), -1);
  std::vector<vtkIdType> used;
  vtkIdType n = 0;
  const vtkIdType* ids = nullptr;
  int t = 0;
  for (polys->InitTraversal(); polys->GetNextCell(n, ids); ++t) {
    DG_CHECK(n == 3);  // flying edges and both decimations make triangles only
    for (int c = 0; c < 3; ++c) {
      if (new_id[ids[c]] < 0) new_id[ids[c]] = static_cast<int>(used.size()), used.push_back(ids[c]);
      surface.triangles(c, t) = new_id[ids[c]];
    }
  }
  surface.vertices_m.resize(3, static_cast<Eigen::Index>(used.size()));
  for (std::size_t v = 0; v < used.size(); ++v) {
    double ijk[3];
    poly->GetPoint(used[v], ijk);
    surface.vertices_m.col(v) = blocks.grid.PointOf(ijk[0], ijk[1], ijk[2]);
  }
  return surface;
}

// One way of making the surface; ExtractSurface tries several in turn.
struct Attempt {
  double sigma_voxels = 0;
  bool preserve_topology = false;  // vtkDecimatePro instead of quadric edge collapse
};

std::vector<Attempt> Attempts(const SurfaceOptions& options) {
  std::vector<Attempt> attempts;
  std::vector<double> sigmas{options.image_smoothing_sigma_voxels};
  for (double extra : kExtraBlursVoxels) sigmas.push_back(options.image_smoothing_sigma_voxels + extra);
  for (double sigma : sigmas) {
    attempts.push_back({sigma, false});
    attempts.push_back({sigma, true});
  }
  return attempts;
}

struct Made {
  io::SurfaceMesh surface;
  int extracted_triangles = 0;
};

Made MakeSurface(const ExtractionImage& blocks, const SurfaceOptions& options, const Attempt& attempt) {
  // The blur is in the extraction grid's cells (the CT's voxels, or blocks
  // of them): relative to the detail the surface is made with, so that a
  // blur of a few cells rounds the same features on a 0.6 mm scan as on a
  // 3 mm one.
  const Eigen::Vector3d sigma_blocks = Eigen::Vector3d::Constant(attempt.sigma_voxels);
  // Three standard deviations of empty padding: the blur of a mask that
  // touches the grid's edge still falls to 0 inside the padded image.
  const int pad = 1 + static_cast<int>(std::ceil(3 * sigma_blocks.maxCoeff()));
  vtkSmartPointer<vtkImageData> image = PaddedImage(blocks, pad, sigma_blocks);

  vtkNew<vtkFlyingEdges3D> flying_edges;
  flying_edges->SetInputData(image);
  flying_edges->SetValue(0, 0.5);
  flying_edges->ComputeNormalsOff();
  flying_edges->ComputeGradientsOff();
  flying_edges->ComputeScalarsOff();

  // The outer surface of the largest piece: noise and cavities (whose
  // surfaces are separate regions) are dropped, as the solid assumes
  // (docs/preop.md, "What we assume").
  vtkNew<vtkPolyDataConnectivityFilter> largest;
  largest->SetInputConnection(flying_edges->GetOutputPort());
  largest->SetExtractionModeToLargestRegion();
  largest->Update();
  const vtkIdType extracted = largest->GetOutput()->GetNumberOfPolys();
  if (extracted == 0) {
    throw Error(fmt::format("no surface at the mask's half level after a blur of {:g} voxels: the mask's {} voxels "
                            "are too thin or too few",
                            attempt.sigma_voxels, blocks.voxels_inside),
                kWhere, "check the mask (a label that only a few voxels carry?), or blur it less");
  }

  vtkNew<vtkWindowedSincPolyDataFilter> smoother;
  smoother->SetInputConnection(largest->GetOutputPort());
  smoother->SetNumberOfIterations(options.smoothing_iterations);
  smoother->SetPassBand(options.smoothing_pass_band);
  smoother->NormalizeCoordinatesOn();  // the pass band's scale does not depend on the grid's size
  smoother->FeatureEdgeSmoothingOff();
  smoother->BoundarySmoothingOff();
  smoother->NonManifoldSmoothingOn();

  const double reduction = std::max(0.0, 1.0 - static_cast<double>(options.target_triangles) / extracted);
  vtkSmartPointer<vtkPolyDataAlgorithm> decimation;
  if (attempt.preserve_topology) {
    auto pro = vtkSmartPointer<vtkDecimatePro>::New();
    pro->SetTargetReduction(reduction);
    pro->PreserveTopologyOn();
    pro->SplittingOff();
    pro->BoundaryVertexDeletionOff();
    decimation = pro;
  } else {
    auto quadric = vtkSmartPointer<vtkQuadricDecimation>::New();
    quadric->SetTargetReduction(reduction);
    quadric->VolumePreservationOn();
    decimation = quadric;
  }
  decimation->SetInputConnection(smoother->GetOutputPort());
  decimation->Update();

  Made made{ToSurfaceMesh(decimation->GetOutput(), blocks), static_cast<int>(extracted)};
  // Flying edges winds its triangles by the image's axes; a mirroring
  // direction (determinant -1) turns them inside out.
  if (SixEnclosedVolume(made.surface) < 0) made.surface.triangles.row(1).swap(made.surface.triangles.row(2));
  return made;
}

// Union-find over vertex ids, for the surface's components.
int Find(std::vector<int>& parent, int a) {
  while (parent[a] != a) a = parent[a] = parent[parent[a]];
  return a;
}

}  // namespace

std::string SurfaceOptions::Validate() const {
  if (!(image_smoothing_sigma_voxels >= 0 && image_smoothing_sigma_voxels <= 10)) {
    return fmt::format("image_smoothing_sigma_voxels must lie in [0, 10], got {:g}", image_smoothing_sigma_voxels);
  }
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

bool SurfaceTopology::IsClosedManifoldSphere() const {
  return triangles > 0 && boundary_edges == 0 && non_manifold_edges == 0 && misoriented_edges == 0 &&
         non_manifold_vertices == 0 && components == 1 && euler_characteristic == 2;
}

std::string SurfaceTopology::Describe() const {
  if (IsClosedManifoldSphere()) return fmt::format("closed manifold of genus 0, {} triangles", triangles);
  std::vector<std::string> faults;
  if (triangles == 0) faults.push_back("no triangle");
  if (boundary_edges) faults.push_back(fmt::format("{} boundary edges (holes)", boundary_edges));
  if (non_manifold_edges) faults.push_back(fmt::format("{} edges in three triangles or more", non_manifold_edges));
  if (misoriented_edges) faults.push_back(fmt::format("{} edges between inconsistently oriented triangles",
                                                      misoriented_edges));
  if (non_manifold_vertices) faults.push_back(fmt::format("{} vertices where parts touch", non_manifold_vertices));
  if (components != 1) faults.push_back(fmt::format("{} components", components));
  if (faults.empty() || euler_characteristic != 2) {
    faults.push_back(fmt::format("Euler characteristic {} (2 for a sphere; {} tunnels if closed)",
                                 euler_characteristic, std::max(0, (2 - euler_characteristic) / 2)));
  }
  std::string text = fmt::format("{}", fmt::join(faults, ", "));
  if (has_fault_location) {
    text += fmt::format("; one at ({:.1f}, {:.1f}, {:.1f}) mm", 1e3 * first_fault_m.x(), 1e3 * first_fault_m.y(),
                        1e3 * first_fault_m.z());
  }
  return text;
}

SurfaceTopology CheckSurfaceTopology(const io::SurfaceMesh& surface) {
  SurfaceTopology topology;
  topology.triangles = surface.num_triangles();
  const auto& f = surface.triangles;
  auto note_fault = [&](const Eigen::Vector3d& x_m) {
    if (!topology.has_fault_location) topology.first_fault_m = x_m, topology.has_fault_location = true;
  };

  // Each undirected edge: how many triangles run along it a -> b (a < b) and b -> a.
  std::map<std::pair<int, int>, std::pair<int, int>> runs;
  std::vector<int> parent(surface.num_vertices());
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<bool> used(surface.num_vertices(), false);
  for (int t = 0; t < f.cols(); ++t) {
    for (int c = 0; c < 3; ++c) {
      const int a = f(c, t), b = f((c + 1) % 3, t);
      auto& [forward, backward] = runs[std::minmax(a, b)];
      ++(a < b ? forward : backward);
      used[a] = true;
      parent[Find(parent, a)] = Find(parent, b);
    }
  }
  topology.edges = static_cast<int>(runs.size());
  for (const auto& [edge, count] : runs) {
    const auto [forward, backward] = count;
    const Eigen::Vector3d midpoint_m = 0.5 * (surface.vertices_m.col(edge.first) + surface.vertices_m.col(edge.second));
    if (forward + backward == 1) {
      ++topology.boundary_edges, note_fault(midpoint_m);
    } else if (forward + backward > 2) {
      ++topology.non_manifold_edges, note_fault(midpoint_m);
    } else if (forward != 1) {
      ++topology.misoriented_edges, note_fault(midpoint_m);
    }
  }

  // Around a manifold vertex the triangles (v, a, b) chain a -> b into one cycle.
  std::vector<std::vector<std::pair<int, int>>> fans(surface.num_vertices());
  for (int t = 0; t < f.cols(); ++t) {
    for (int c = 0; c < 3; ++c) fans[f(c, t)].emplace_back(f((c + 1) % 3, t), f((c + 2) % 3, t));
  }
  for (int v = 0; v < surface.num_vertices(); ++v) {
    if (!used[v]) continue;
    ++topology.vertices;
    if (Find(parent, v) == v) ++topology.components;
    std::map<int, int> next(fans[v].begin(), fans[v].end());
    if (next.size() != fans[v].size()) continue;  // an edge fault, counted above
    int cycle = 1;
    for (int a = next.begin()->second; a != next.begin()->first && cycle <= static_cast<int>(next.size()); ++cycle) {
      const auto it = next.find(a);
      if (it == next.end()) break;
      a = it->second;
    }
    if (cycle != static_cast<int>(next.size())) {
      ++topology.non_manifold_vertices, note_fault(surface.vertices_m.col(v));
    }
  }
  topology.euler_characteristic = topology.vertices - topology.edges + topology.triangles;
  return topology;
}

io::SurfaceMesh ExtractSurface(const VoxelMask& mask, const SurfaceOptions& options, SurfaceReport* report) {
  if (std::string problem = options.Validate(); !problem.empty()) {
    throw Error("invalid surface options: " + problem, kWhere, "correct the option");
  }
  if (mask.Count() == 0) {
    throw Error("the mask is empty: there is no surface to extract", kWhere,
                "check the segmentation that made the mask");
  }
  const ExtractionImage blocks = BlockFractions(mask, BlockFactors(mask, options.target_triangles));
  std::string failures;
  int attempts = 0;
  for (const Attempt& attempt : Attempts(options)) {
    ++attempts;
    Made made = MakeSurface(blocks, options, attempt);
    const SurfaceTopology topology = CheckSurfaceTopology(made.surface);
    const std::string how = fmt::format("blur {:g} voxels, {} decimation", attempt.sigma_voxels,
                                        attempt.preserve_topology ? "topology-preserving" : "quadric");
    if (options.require_solid_ball && !topology.IsClosedManifoldSphere()) {
      failures += fmt::format("\n  {}: {}", how, topology.Describe());
      continue;
    }
    if (attempts > 1) Logger("stages").info("{}: surface made with {} after:{}", kWhere, how, failures);
    if (report) {
      *report = {made.extracted_triangles, made.surface.num_triangles(), SixEnclosedVolume(made.surface) / 6,
                 attempts, attempt.sigma_voxels, attempt.preserve_topology};
    }
    return std::move(made.surface);
  }
  throw NotASolidBall(fmt::format("the mask's surface ({} voxels) is not the boundary of one solid ball, "
                          "which the mesher needs, in any of {} attempts:{}",
                          mask.Count(), attempts, failures),
              kWhere,
              fmt::format("blur the mask more (preop --smoothing-voxels, now {:g}) or ask for another triangle "
                          "count (--triangles, now {}); tunnels through the organ must be filled in the mask",
                          options.image_smoothing_sigma_voxels, options.target_triangles));
}

}  // namespace dg::stages::preop
