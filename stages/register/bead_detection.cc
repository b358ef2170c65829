#include "stages/register/bead_detection.h"

#include <algorithm>
#include <limits>

#include "sim/error.h"

namespace dg::stages {

std::string BeadDetectionOptions::Validate() const {
  if (!(threshold_hu > background_hu)) return "threshold_hu must exceed background_hu";
  if (min_voxels < 1) return "min_voxels must be at least 1";
  return {};
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
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        double weight = 0;
        for (const auto* voxels : {&inside, &rim}) {
          for (const Eigen::Vector3i& v : *voxels) {
            const double w = std::max(0.0, volume.at(v.x(), v.y(), v.z()) - options.background_hu);
            sum += w * v.cast<double>();
            weight += w;
          }
        }
        beads.push_back(volume.origin_m + volume.spacing_m.cwiseProduct(sum / weight));
      }
    }
  }
  return beads;
}

FiducialMotion DetectBeadMotion(const std::vector<std::string>& ct_volumes, const BeadDetectionOptions& options) {
  FiducialMotion motion;
  const int P = static_cast<int>(ct_volumes.size());
  for (int k = 0; k < P; ++k) {
    const std::vector<Eigen::Vector3d> beads = DetectBeads(io::ReadMetaImage<std::int16_t>(ct_volumes[k]), options);
    if (beads.empty()) {
      throw Error("no bead above " + std::to_string(options.threshold_hu) + " HU", ct_volumes[k],
                  "check the volume holds the fiducial beads, or lower the threshold");
    }
    Eigen::Matrix3Xd positions(3, beads.size());
    if (k == 0) {
      for (size_t b = 0; b < beads.size(); ++b) positions.col(b) = beads[b];
    } else {
      const Eigen::Matrix3Xd& previous = motion.positions_S_m.back();
      if (static_cast<Eigen::Index>(beads.size()) != previous.cols()) {
        throw Error(std::to_string(beads.size()) + " beads but phase 0 has " + std::to_string(previous.cols()),
                    ct_volumes[k], "check the threshold (a bead merged with another, or noise above it)");
      }
      std::vector<bool> taken(beads.size(), false);
      for (Eigen::Index f = 0; f < previous.cols(); ++f) {
        size_t nearest = 0;
        double best = std::numeric_limits<double>::infinity();
        for (size_t b = 0; b < beads.size(); ++b) {
          const double d = (beads[b] - previous.col(f)).norm();
          if (d < best) {
            best = d;
            nearest = b;
          }
        }
        if (taken[nearest]) {
          throw Error("two beads of the phase before are nearest to one bead here", ct_volumes[k],
                      "use more phases, so that beads move less between phases than they are apart");
        }
        taken[nearest] = true;
        positions.col(f) = beads[nearest];
      }
    }
    motion.phases.push_back(double(k) / P);
    motion.positions_S_m.push_back(positions);
  }
  return motion;
}

}  // namespace dg::stages
