#include "stages/register/bead_detection.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "sim/error.h"

namespace dg::stages {
namespace {

std::string Millimetres(const Eigen::Vector3d& p_m) {
  return fmt::format("({:.1f}, {:.1f}, {:.1f})", 1e3 * p_m.x(), 1e3 * p_m.y(), 1e3 * p_m.z());
}

// The diameter of a sphere of `voxels` voxels.
double EquivalentDiameter_mm(std::size_t voxels, const Eigen::Vector3d& spacing_m) {
  const double volume_mm3 = static_cast<double>(voxels) * 1e9 * spacing_m.prod();
  return std::cbrt(6 * volume_mm3 / std::numbers::pi);
}

}  // namespace

std::string BeadDetectionOptions::Validate() const {
  if (!(threshold_hu > background_hu)) return "threshold_hu must exceed background_hu";
  if (min_voxels < 1) return "min_voxels must be at least 1";
  if (!(min_diameter_mm >= 0) || !(max_diameter_mm > min_diameter_mm)) {
    return fmt::format("the bead size range must be 0 <= min < max mm, got {:g}-{:g}", min_diameter_mm,
                       max_diameter_mm);
  }
  return {};
}

std::string BeadDetectionOptions::Describe() const {
  std::string text = fmt::format("above {:g} HU, {:g}-{:g} mm across", threshold_hu, min_diameter_mm, max_diameter_mm);
  if (HasRoi()) text += ", in the box " + Millimetres(roi_min_m) + "-" + Millimetres(roi_max_m) + " mm";
  return text;
}

std::vector<Eigen::Vector3d> DetectBeads(const io::VolumeI16& volume, const BeadDetectionOptions& options) {
  if (const std::string wrong = options.Validate(); !wrong.empty()) {
    throw Error("invalid bead detection options: " + wrong, "bead detection", "correct the option");
  }
  const Eigen::Vector3i& n = volume.size;
  // label: -1 unvisited, c >= 0 inside component c, -2 - c on component c's rim.
  std::vector<int> label(volume.num_voxels(), -1);
  std::vector<Eigen::Vector3d> beads;
  int components = 0;
  for (int k = 0; k < n.z(); ++k) {
    for (int j = 0; j < n.y(); ++j) {
      for (int i = 0; i < n.x(); ++i) {
        if (volume.at(i, j, k) <= options.threshold_hu || label[volume.Index(i, j, k)] >= 0) continue;
        const int id = components++;
        label[volume.Index(i, j, k)] = id;
        std::vector<Eigen::Vector3i> stack{{i, j, k}}, inside, rim;
        while (!stack.empty()) {
          const Eigen::Vector3i v = stack.back();
          stack.pop_back();
          inside.push_back(v);
          for (int d = 0; d < 27; ++d) {
            const Eigen::Vector3i w = v + Eigen::Vector3i(d % 3 - 1, d / 3 % 3 - 1, d / 9 - 1);
            if ((w.array() < 0).any() || (w.array() >= n.array()).any()) continue;
            const size_t index = volume.Index(w.x(), w.y(), w.z());
            if (volume.values[index] > options.threshold_hu) {
              if (label[index] < 0) {
                label[index] = id;
                stack.push_back(w);
              }
            } else if (label[index] != -2 - id) {
              label[index] = -2 - id;
              rim.push_back(w);
            }
          }
        }
        if (static_cast<int>(inside.size()) < options.min_voxels) continue;
        const double diameter_mm = EquivalentDiameter_mm(inside.size(), volume.spacing_m);
        if (diameter_mm < options.min_diameter_mm || diameter_mm > options.max_diameter_mm) continue;
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        double weight = 0;
        for (const auto* voxels : {&inside, &rim}) {
          for (const Eigen::Vector3i& v : *voxels) {
            const double w = std::max(0.0, volume.at(v.x(), v.y(), v.z()) - options.background_hu);
            sum += w * v.cast<double>();
            weight += w;
          }
        }
        const Eigen::Vector3d bead = volume.origin_m + volume.spacing_m.cwiseProduct(sum / weight);
        if (options.HasRoi() &&
            ((bead.array() < options.roi_min_m.array()).any() || (bead.array() > options.roi_max_m.array()).any())) {
          continue;
        }
        beads.push_back(bead);
      }
    }
  }
  return beads;
}

std::vector<std::vector<Eigen::Vector3d>> DetectBeadsInPhases(const std::vector<std::string>& ct_volumes,
                                                              const BeadDetectionOptions& options) {
  std::vector<std::vector<Eigen::Vector3d>> beads;
  for (const std::string& volume : ct_volumes) beads.push_back(DetectBeads(io::ReadMetaImage<std::int16_t>(volume), options));
  return beads;
}

namespace {

// Every phase's bead count, and phase 0's beads, for an error about them.
std::string WhatWasFound(const std::vector<std::vector<Eigen::Vector3d>>& beads, const BeadDetectionOptions& options) {
  std::string text = "beads " + options.Describe() + " per phase:";
  for (size_t k = 0; k < beads.size(); ++k) text += fmt::format(" {}", beads[k].size());
  if (!beads.front().empty()) {
    text += "; phase 0's at";
    constexpr size_t kListed = 12;
    for (size_t b = 0; b < std::min(kListed, beads.front().size()); ++b) text += " " + Millimetres(beads.front()[b]);
    if (beads.front().size() > kListed) text += fmt::format(" and {} more", beads.front().size() - kListed);
    text += " mm";
  }
  return text;
}

}  // namespace

FiducialMotion MatchBeadsAcrossPhases(const std::vector<std::vector<Eigen::Vector3d>>& beads,
                                      const std::vector<std::string>& ct_volumes, const BeadDetectionOptions& options) {
  FiducialMotion motion;
  const int P = static_cast<int>(beads.size());
  const size_t F = beads.front().size();
  for (int k = 0; k < P; ++k) {
    if (beads[k].size() != F) {
      throw Error(fmt::format("phase {} has {} beads but phase 0 has {} ({})", k, beads[k].size(), F,
                              WhatWasFound(beads, options)),
                  ct_volumes[k],
                  "set the bead threshold, size range or region (preop --bead-min-hu, --bead-size-mm, --roi) so "
                  "that bone and contrast are left out, or give the fiducials in a file (--fiducials)");
    }
    Eigen::Matrix3Xd positions(3, F);
    if (k == 0) {
      for (size_t b = 0; b < F; ++b) positions.col(b) = beads[k][b];
    } else {
      const Eigen::Matrix3Xd& previous = motion.positions_S_m.back();
      std::vector<bool> taken(F, false);
      for (Eigen::Index f = 0; f < previous.cols(); ++f) {
        size_t nearest = 0;
        double best = std::numeric_limits<double>::infinity();
        for (size_t b = 0; b < F; ++b) {
          const double d = (beads[k][b] - previous.col(f)).norm();
          if (d < best) {
            best = d;
            nearest = b;
          }
        }
        if (taken[nearest]) {
          throw Error(fmt::format("two beads of phase {} are nearest to one bead of phase {}, at {} mm ({})", k - 1, k,
                                  Millimetres(beads[k][nearest]), WhatWasFound(beads, options)),
                      ct_volumes[k], "use more phases, so that beads move less between phases than they are apart");
        }
        taken[nearest] = true;
        positions.col(f) = beads[k][nearest];
      }
    }
    motion.phases.push_back(double(k) / P);
    motion.positions_S_m.push_back(positions);
  }
  return motion;
}

FiducialMotion DetectBeadMotion(const std::vector<std::string>& ct_volumes, const BeadDetectionOptions& options) {
  const std::vector<std::vector<Eigen::Vector3d>> beads = DetectBeadsInPhases(ct_volumes, options);
  if (beads.front().empty()) {
    throw Error("no bead " + options.Describe() + " in phase 0", ct_volumes.front(),
                "check the volume holds the fiducial beads, or set the bead threshold and size range");
  }
  return MatchBeadsAcrossPhases(beads, ct_volumes, options);
}

}  // namespace dg::stages
