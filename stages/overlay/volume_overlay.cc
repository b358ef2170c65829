#include "stages/overlay/volume_overlay.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include "sim/error.h"

namespace dg::stages::overlay {
namespace {

// As the rasterizer's: cut edges far off the image never show, and projected
// coordinates stay within the fixed-point set-up's range.
constexpr double kGuardBandPx = 4096;
constexpr int kCutBlock = 256;  // elements per task; fixed, so the order never depends on the threads
constexpr int kLutFirstHu = -1024;
constexpr std::array<std::array<int, 2>, 6> kEdges{{{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}}};

const VolumeOverlay::Options& CheckedOptions(const VolumeOverlay::Options& options, const LensView& view) {
  if (const std::string problem = options.Validate(); !problem.empty())
    throw Error("invalid volume overlay options: " + problem, "overlay options", "correct the scene's volume settings");
  const int d = options.resolution_divisor;
  if (view.pinhole().width % d != 0 || view.pinhole().height % d != 0) {
    throw Error("resolution divisor " + std::to_string(d) + " does not divide the image's " +
                    std::to_string(view.pinhole().width) + "x" + std::to_string(view.pinhole().height) + " pixels",
                "volume overlay options", "choose a divisor of both the width and the height (1, 2 or 4 for 640x480)");
  }
  return options;
}

// The camera that samples every d-th pixel's neighbourhood: pixel u' of it
// covers the full camera's pixels d u' .. d u' + d - 1, its centre at
// u = d u' + (d - 1) / 2, as PinholeCamera::Supersampled inverts; bilinear
// resampling with pixel centres aligned (cv::resize) maps it back.
render::PinholeCamera Reduced(const render::PinholeCamera& camera, int d) {
  render::PinholeCamera reduced = camera;
  reduced.fx = camera.fx / d;
  reduced.fy = camera.fy / d;
  reduced.cx = (camera.cx - (d - 1) / 2.0) / d;
  reduced.cy = (camera.cy - (d - 1) / 2.0) / d;
  reduced.width = camera.width / d;
  reduced.height = camera.height / d;
  return reduced;
}

// The full view's ray lengths, averaged over each reduced pixel's block.
cv::Mat ReducedRayLength(const LensView& view, int d) {
  const cv::Mat full = view.RayLengthPerDepth();
  if (d == 1) return full;
  cv::Mat reduced;
  cv::resize(full, reduced, cv::Size(full.cols / d, full.rows / d), 0, 0, cv::INTER_AREA);
  return reduced;
}

// The convex polygon where the plane z = z_cut meets an element, corners in
// order around it; attributes (CT voxel coordinates) ride in normal_C, which
// clipping interpolates linearly like the position. Each crossing edge is
// interpolated from its lower node id, so neighbours sharing the edge make
// bit-identical corners. Returns the corner count (0, 3 or 4).
int CutElement(const std::array<int, 4>& nodes, const Eigen::Matrix3Xd& view, const Eigen::Matrix3Xf& voxels,
               double z_cut, std::array<render::ClipVertex, 4>* corners) {
  int count = 0;
  for (const auto& [i, j] : kEdges) {
    int a = nodes[i], b = nodes[j];
    if (a > b) std::swap(a, b);
    const double za = view(2, a), zb = view(2, b);
    if ((za >= z_cut) == (zb >= z_cut)) continue;
    const double t = (z_cut - za) / (zb - za);
    render::ClipVertex& corner = (*corners)[count++];
    corner.position_C = view.col(a) + t * (view.col(b) - view.col(a));
    corner.position_C.z() = z_cut;
    corner.normal_C = voxels.col(a) + static_cast<float>(t) * (voxels.col(b) - voxels.col(a));
    corner.uv.setZero();
  }
  if (count == 4) {
    // Two corners of a quad are opposite when the other two lie on either side
    // of the line through them; 0 and its opposite must not be neighbours.
    const auto side = [&](int from, int to, int p) {
      const Eigen::Vector2d d = ((*corners)[to].position_C - (*corners)[from].position_C).head<2>();
      const Eigen::Vector2d q = ((*corners)[p].position_C - (*corners)[from].position_C).head<2>();
      return d.x() * q.y() - d.y() * q.x();
    };
    if (side(0, 1, 2) * side(0, 1, 3) < 0) std::swap((*corners)[1], (*corners)[2]);       // 0-1 a diagonal
    else if (side(0, 3, 1) * side(0, 3, 2) < 0) std::swap((*corners)[3], (*corners)[2]);  // 0-3 a diagonal
  }
  return count;
}

}  // namespace

std::string VolumeOverlay::Options::Validate() const {
  if (!(slice_spacing_m > 1e-6 && slice_spacing_m < 0.1)) return "slice_spacing_m must be within (1 um, 10 cm)";
  if (!(opacity >= 0 && opacity <= 1)) return "opacity must be within [0, 1]";
  if (reserved_layers < 1) return "reserved_layers must be at least 1 (the layer being drawn)";
  if (resolution_divisor < 1 || resolution_divisor > 8) return "resolution_divisor must be within [1, 8]";
  return {};
}

VolumeOverlay::VolumeOverlay(const Options& options, const sim::TetMesh& mesh, std::shared_ptr<const io::VolumeI16> ct,
                             const TransferFunction& transfer, const LensView& view)
    : options_(CheckedOptions(options, view)),
      num_nodes_(mesh.num_nodes()),
      tets_(mesh.tets),
      ct_(std::move(ct)),
      view_(view),
      camera_(Reduced(view.pinhole(), options.resolution_divisor)),
      ray_length_(ReducedRayLength(view, options.resolution_divisor)),
      clipper_(camera_, kGuardBandPx) {
  if (const std::string problem = transfer.Validate(); !problem.empty())
    throw Error("invalid transfer function: " + problem, "volume overlay", "correct the scene's transfer function");
  if (!ct_ || ct_->size.minCoeff() < 2 || ct_->values.size() != ct_->num_voxels())
    throw Error("the CT volume is missing, has fewer than 2 voxels along an axis or the wrong number of values",
                "volume overlay", "give the CT phase of the mesh's reference configuration");
  voxel_nodes_ =
      ((mesh.X_m.colwise() - ct_->origin_m).array().colwise() / ct_->spacing_m.array()).matrix().cast<float>();
  for (int i = 0; i < kLutSize; ++i) {
    const TransferFunction::Point p = transfer.At(static_cast<float>(kLutFirstHu + i));
    lut_[i] = {p.bgr[0], p.bgr[1], p.bgr[2], p.sigma_per_m};
  }
  tiles_x_ = (camera_.width + kTileSize - 1) / kTileSize;
  tiles_y_ = (camera_.height + kTileSize - 1) / kTileSize;
  if (options_.resolution_divisor > 1) reduced_.create(camera_.height, camera_.width, CV_32FC4);
  bins_.resize(static_cast<size_t>(tiles_x_) * tiles_y_);
  layers_.Reserve(options_.reserved_layers, {view.pinhole().width, view.pinhole().height});
}

OverlayLayer VolumeOverlay::Process(const Eigen::Matrix3Xd& nodes_S, std::int64_t frame) {
  if (nodes_S.cols() != num_nodes_)
    throw Error("node positions for " + std::to_string(nodes_S.cols()) + " nodes, the mesh has " +
                    std::to_string(num_nodes_),
                "volume overlay, frame " + std::to_string(frame), "pass the simulation mesh's current node positions");
  const render::PinholeCamera& full = view_.pinhole();
  OverlayLayer layer{layers_.Take({full.width, full.height}), frame};
  cv::Mat& target = options_.resolution_divisor > 1 ? reduced_ : layer.bgra;
  target.setTo(cv::Scalar::all(0));
  view_.ToView(nodes_S, &nodes_view_);
  // Slices at the centres of equal intervals over the mesh's depth in front of the near plane.
  const double z_min = std::max(camera_.near_m, nodes_view_.row(2).minCoeff());
  const double z_max = nodes_view_.row(2).maxCoeff();
  last_slices_ = 0;
  last_triangles_ = 0;
  if (z_max > z_min) {
    last_slices_ = std::max(1, static_cast<int>(std::ceil((z_max - z_min) / options_.slice_spacing_m)));
    const double spacing = (z_max - z_min) / last_slices_;
    CutElements(z_min, spacing, last_slices_);
    BinTriangles();
    tbb::parallel_for(0, tiles_x_ * tiles_y_, [&](int tile) {
      if (!bins_[tile].empty()) CompositeTile(tile, static_cast<float>(spacing), &target);
    });
  }
  if (options_.resolution_divisor > 1) cv::resize(reduced_, layer.bgra, layer.bgra.size(), 0, 0, cv::INTER_LINEAR);
  return layer;
}

void VolumeOverlay::CutElements(double z_first, double spacing, int slices) {
  const int num_tets = static_cast<int>(tets_.cols());
  const int num_blocks = (num_tets + kCutBlock - 1) / kCutBlock;
  blocks_.resize(std::max<size_t>(blocks_.size(), num_blocks));
  for (auto& block : blocks_) block.clear();
  const render::PinholeCamera& camera = camera_;
  tbb::parallel_for(0, num_blocks, [&](int b) {
    std::vector<SliceTriangle>& out = blocks_[b];
    std::vector<render::ScreenTriangle> screen;
    render::ClipPolygon polygon;
    std::array<render::ClipVertex, 4> corners;
    const int end = std::min(num_tets, (b + 1) * kCutBlock);
    for (int e = b * kCutBlock; e < end; ++e) {
      const std::array<int, 4> nodes{tets_(0, e), tets_(1, e), tets_(2, e), tets_(3, e)};
      double lo = nodes_view_(2, nodes[0]), hi = lo;
      for (int k = 1; k < 4; ++k) {
        lo = std::min(lo, nodes_view_(2, nodes[k]));
        hi = std::max(hi, nodes_view_(2, nodes[k]));
      }
      // Slice k at z_first + (k + 1/2) spacing.
      const int first = std::max(0, static_cast<int>(std::ceil((lo - z_first) / spacing - 0.5)));
      const int last = std::min(slices - 1, static_cast<int>(std::floor((hi - z_first) / spacing - 0.5)));
      for (int k = first; k <= last; ++k) {
        const double z_cut = z_first + (k + 0.5) * spacing;
        const int count = CutElement(nodes, nodes_view_, voxel_nodes_, z_cut, &corners);
        for (int fan = 1; fan + 1 < count; ++fan) {
          clipper_.Clip({corners[0], corners[fan], corners[fan + 1]}, &polygon);
          screen.clear();
          render::AppendScreenTriangles(camera, polygon, &screen);
          for (const render::ScreenTriangle& t : screen) {
            // Voxel coordinates: sum_k V_k d_k / sum_k d_k, with sum_k d_k
            // constant over a plane z = const (triangle_setup.h): affine.
            Eigen::Vector3d weight_sum = Eigen::Vector3d::Zero();
            Eigen::Matrix3d numerator = Eigen::Matrix3d::Zero();
            for (int c = 0; c < 3; ++c) {
              weight_sum += t.ray_weight[c];
              numerator += t.normal_C[c].cast<double>() * t.ray_weight[c].transpose();
            }
            const Eigen::Vector3d centre(0.5 * (t.min_x + t.max_x), 0.5 * (t.min_y + t.max_y), 1);
            const Eigen::Matrix3d affine = numerator / weight_sum.dot(centre);
            const Eigen::Vector3d at_min = affine * Eigen::Vector3d(t.min_x, t.min_y, 1);
            out.push_back({t, Eigen::Vector3f(at_min.cast<float>()), Eigen::Vector3f(affine.col(0).cast<float>()),
                            Eigen::Vector3f(affine.col(1).cast<float>()), k});
          }
        }
      }
    }
  });
}

void VolumeOverlay::BinTriangles() {
  // Back to front: counting sort by slice, farthest first, element order within a slice.
  ordered_.clear();
  std::vector<int> starts(last_slices_ + 1, 0);
  for (const auto& block : blocks_) {
    for (const SliceTriangle& t : block) ++starts[last_slices_ - 1 - t.slice + 1];
  }
  for (int s = 0; s < last_slices_; ++s) starts[s + 1] += starts[s];
  ordered_.resize(starts.back());
  for (const auto& block : blocks_) {
    for (const SliceTriangle& t : block) ordered_[starts[last_slices_ - 1 - t.slice]++] = &t;
  }
  last_triangles_ = ordered_.size();
  for (auto& bin : bins_) bin.clear();
  for (const SliceTriangle* t : ordered_) {
    for (int ty = t->screen.min_y / kTileSize; ty <= t->screen.max_y / kTileSize; ++ty) {
      for (int tx = t->screen.min_x / kTileSize; tx <= t->screen.max_x / kTileSize; ++tx)
        bins_[ty * tiles_x_ + tx].push_back(t);
    }
  }
}

float VolumeOverlay::SampleHu(const Eigen::Vector3f& voxel) const {
  // Trilinear, clamped to the volume (its border voxels continue outwards).
  const io::VolumeI16& ct = *ct_;
  int index[3];
  float frac[3];
  for (int i = 0; i < 3; ++i) {
    const float v = std::clamp(voxel[i], 0.0f, static_cast<float>(ct.size[i] - 1));
    index[i] = std::min(static_cast<int>(v), ct.size[i] - 2);
    frac[i] = v - static_cast<float>(index[i]);
  }
  const size_t sx = 1, sy = static_cast<size_t>(ct.size.x()), sz = sy * ct.size.y();
  const std::int16_t* p = ct.values.data() + ct.Index(index[0], index[1], index[2]);
  const auto lerp = [](float a, float b, float t) { return a + t * (b - a); };
  const float c00 = lerp(p[0], p[sx], frac[0]), c10 = lerp(p[sy], p[sy + sx], frac[0]);
  const float c01 = lerp(p[sz], p[sz + sx], frac[0]), c11 = lerp(p[sz + sy], p[sz + sy + sx], frac[0]);
  return lerp(lerp(c00, c10, frac[1]), lerp(c01, c11, frac[1]), frac[2]);
}

void VolumeOverlay::CompositeTile(int tile, float spacing, cv::Mat* bgra) const {
  const int x0 = (tile % tiles_x_) * kTileSize, y0 = (tile / tiles_x_) * kTileSize;
  const int x1 = std::min(x0 + kTileSize, bgra->cols) - 1, y1 = std::min(y0 + kTileSize, bgra->rows) - 1;
  for (const SliceTriangle* t : bins_[tile]) {
    const render::ScreenTriangle& s = t->screen;
    const int min_x = std::max(x0, s.min_x), max_x = std::min(x1, s.max_x);
    const int min_y = std::max(y0, s.min_y), max_y = std::min(y1, s.max_y);
    if (min_x > max_x || min_y > max_y) continue;
    const render::EdgeFunction& e0 = s.edge[0];
    const render::EdgeFunction& e1 = s.edge[1];
    const render::EdgeFunction& e2 = s.edge[2];
    for (int y = min_y; y <= max_y; ++y) {
      std::int64_t f0 = e0.At(min_x, y) + e0.bias, f1 = e1.At(min_x, y) + e1.bias, f2 = e2.At(min_x, y) + e2.bias;
      cv::Vec4f* out = bgra->ptr<cv::Vec4f>(y);
      const float* ray = ray_length_.ptr<float>(y);
      Eigen::Vector3f voxel = t->voxel_at_min + static_cast<float>(y - s.min_y) * t->voxel_dy +
                              static_cast<float>(min_x - s.min_x) * t->voxel_dx;
      for (int x = min_x; x <= max_x; ++x, f0 += e0.step_x, f1 += e1.step_x, f2 += e2.step_x, voxel += t->voxel_dx) {
        if ((f0 | f1 | f2) < 0) continue;
        const float hu = SampleHu(voxel);
        const int entry = std::clamp(static_cast<int>(hu - kLutFirstHu + 0.5f), 0, kLutSize - 1);  // nearest HU
        const Classified& c = lut_[entry];
        if (c.sigma_per_m <= 0) continue;
        const float alpha = 1 - std::exp(-c.sigma_per_m * spacing * ray[x]);
        cv::Vec4f& p = out[x];
        p = cv::Vec4f(alpha * c.b, alpha * c.g, alpha * c.r, alpha) + (1 - alpha) * p;
      }
    }
  }
  if (options_.opacity == 1.0f) return;
  for (int y = y0; y <= y1; ++y) {
    cv::Vec4f* out = bgra->ptr<cv::Vec4f>(y);
    for (int x = x0; x <= x1; ++x) out[x] *= options_.opacity;
  }
}

}  // namespace dg::stages::overlay
