#include "io/ct/axis_aligned.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include <Eigen/Dense>

#include "sim/log.h"

namespace dg::io {
namespace {

constexpr double kPermutationTolerance = 1e-6;

// The file's grid moved exactly onto S's axes: new index along S axis
// match.axis[a] is i_a, or n_a - 1 - i_a against it.
CtImage Permuted(const CtImage& image, const AxisMatch& match) {
  CtImage aligned = image;
  Eigen::Vector3d corner;  // the old index of the new voxel (0, 0, 0)
  for (int a = 0; a < 3; ++a) {
    aligned.size[match.axis[a]] = image.size[a];
    aligned.spacing_m[match.axis[a]] = image.spacing_m[a];
    corner[a] = match.sign[a] > 0 ? 0 : image.size[a] - 1;
  }
  aligned.origin_m = image.PointOf(corner.x(), corner.y(), corner.z());
  aligned.direction.setIdentity();
  // Strides of the new image along the old voxel axes.
  std::array<std::ptrdiff_t, 3> new_stride{1, aligned.size.x(), std::ptrdiff_t(aligned.size.x()) * aligned.size.y()};
  std::array<std::ptrdiff_t, 3> step{};
  std::ptrdiff_t start = 0;
  for (int a = 0; a < 3; ++a) {
    step[a] = match.sign[a] * new_stride[match.axis[a]];
    if (match.sign[a] < 0) start += (image.size[a] - 1) * new_stride[match.axis[a]];
  }
  size_t v = 0;
  for (int k = 0; k < image.size.z(); ++k) {
    for (int j = 0; j < image.size.y(); ++j) {
      std::ptrdiff_t target = start + k * step[2] + j * step[1];
      for (int i = 0; i < image.size.x(); ++i, ++v, target += step[0]) aligned.values[target] = image.values[v];
    }
  }
  return aligned;
}

// Linear or nearest value at continuous index u, or `outside` beyond the voxels' extent.
float Sample(const CtImage& image, const Eigen::Vector3d& u, Interpolation interpolation, float outside) {
  for (int a = 0; a < 3; ++a) {
    if (u[a] < -0.5 || u[a] > image.size[a] - 0.5) return outside;
  }
  if (interpolation == Interpolation::kNearest) {
    std::array<int, 3> n{};
    for (int a = 0; a < 3; ++a) n[a] = std::clamp(static_cast<int>(std::lround(u[a])), 0, image.size[a] - 1);
    return image.at(n[0], n[1], n[2]);
  }
  std::array<int, 3> lo{}, hi{};
  std::array<double, 3> w{};
  for (int a = 0; a < 3; ++a) {
    const double clamped = std::clamp(u[a], 0.0, image.size[a] - 1.0);
    lo[a] = std::min(static_cast<int>(std::floor(clamped)), image.size[a] - 1);
    hi[a] = std::min(lo[a] + 1, image.size[a] - 1);
    w[a] = clamped - lo[a];
  }
  double value = 0;
  for (int c = 0; c < 8; ++c) {
    const int i = c & 1 ? hi[0] : lo[0], j = c & 2 ? hi[1] : lo[1], k = c & 4 ? hi[2] : lo[2];
    const double weight = (c & 1 ? w[0] : 1 - w[0]) * (c & 2 ? w[1] : 1 - w[1]) * (c & 4 ? w[2] : 1 - w[2]);
    if (weight != 0) value += weight * image.at(i, j, k);
  }
  return static_cast<float>(value);
}

CtImage Resampled(const CtImage& image, const AxisMatch& match, Interpolation interpolation, float outside) {
  Eigen::Vector3d low = Eigen::Vector3d::Constant(INFINITY), high = Eigen::Vector3d::Constant(-INFINITY);
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d corner = image.PointOf(c & 1 ? image.size.x() - 1 : 0, c & 2 ? image.size.y() - 1 : 0,
                                                 c & 4 ? image.size.z() - 1 : 0);
    low = low.cwiseMin(corner);
    high = high.cwiseMax(corner);
  }
  CtImage aligned = image;
  aligned.direction.setIdentity();
  aligned.origin_m = low;
  for (int a = 0; a < 3; ++a) aligned.spacing_m[match.axis[a]] = image.spacing_m[a];
  for (int b = 0; b < 3; ++b) {
    // Enough voxels to reach the far corner; 1e-9 of a voxel is rounding.
    aligned.size[b] = static_cast<int>(std::ceil((high[b] - low[b]) / aligned.spacing_m[b] - 1e-9)) + 1;
  }
  aligned.values.assign(aligned.num_voxels(), outside);
  // Old continuous index of an S point: u = diag(1 / spacing) R^-1 (x - origin).
  const Eigen::Matrix3d to_index = image.spacing_m.cwiseInverse().asDiagonal() * image.direction.inverse();
  const Eigen::Vector3d u0 = to_index * (aligned.origin_m - image.origin_m);
  const Eigen::Matrix3d du = to_index * aligned.spacing_m.asDiagonal();  // column b: u's change per new voxel along b
  size_t v = 0;
  for (int k = 0; k < aligned.size.z(); ++k) {
    for (int j = 0; j < aligned.size.y(); ++j) {
      const Eigen::Vector3d row = u0 + du.col(1) * j + du.col(2) * k;
      for (int i = 0; i < aligned.size.x(); ++i, ++v) {
        aligned.values[v] = Sample(image, row + du.col(0) * i, interpolation, outside);
      }
    }
  }
  return aligned;
}

}  // namespace

std::string AxisMatch::Code() const {
  static constexpr char kAlong[] = "LPS", kAgainst[] = "RAI";
  std::string code;
  for (int a = 0; a < 3; ++a) code += sign[a] > 0 ? kAlong[axis[a]] : kAgainst[axis[a]];
  return code;
}

AxisMatch MatchAxes(const Eigen::Matrix3d& direction) {
  std::array<int, 3> p{0, 1, 2};
  AxisMatch best;
  double best_sum = -1;
  do {
    double sum = 0;
    for (int a = 0; a < 3; ++a) sum += std::abs(direction(p[a], a));
    if (sum > best_sum) {
      best_sum = sum;
      best.axis = Eigen::Vector3i(p[0], p[1], p[2]);
    }
  } while (std::next_permutation(p.begin(), p.end()));
  best.largest_angle_deg = 0;
  best.is_signed_permutation = true;
  for (int a = 0; a < 3; ++a) {
    const double cosine = direction(best.axis[a], a);
    best.sign[a] = cosine < 0 ? -1 : 1;
    const double angle = std::acos(std::min(1.0, std::abs(cosine))) * 180 / M_PI;
    best.largest_angle_deg = std::max(best.largest_angle_deg, angle);
    Eigen::Vector3d axis = Eigen::Vector3d::Zero();
    axis[best.axis[a]] = best.sign[a];
    if ((direction.col(a) - axis).cwiseAbs().maxCoeff() > kPermutationTolerance) best.is_signed_permutation = false;
  }
  return best;
}

CtImage OnAxisAlignedGrid(CtImage image, Interpolation interpolation, float outside_value) {
  const AxisMatch match = MatchAxes(image.direction);
  if (match.is_signed_permutation) {
    if (match.Code() == "LPS") {
      image.direction.setIdentity();  // within 1e-6: header rounding
      return image;
    }
    CtImage aligned = Permuted(image, match);
    aligned.reoriented_from = match.Code();
    return aligned;
  }
  char text[64];
  std::snprintf(text, sizeof text, "oblique %.1f deg", match.largest_angle_deg);
  Logger("io").warn(
      "{}: the voxel axes are oblique to the scan frame's (up to {:.2f} degrees); resampled ({}) onto a grid of "
      "its axes at the image's spacing",
      image.source, match.largest_angle_deg, interpolation == Interpolation::kLinear ? "linear" : "nearest voxel");
  CtImage aligned = Resampled(image, match, interpolation, outside_value);
  aligned.reoriented_from = text;
  aligned.oblique_angle_deg = match.largest_angle_deg;
  return aligned;
}

}  // namespace dg::io
