#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace dg::stages {

// The fiducials' positions in the scan frame S over one cardiac cycle, as the
// 4D scan gives them: positions_S_m[k].col(i) is fiducial i at phase phases[k].
struct FiducialMotion {
  std::vector<double> phases;                  // increasing, in [0, 1)
  std::vector<Eigen::Matrix3Xd> positions_S_m; // one 3xF matrix per phase

  int num_phases() const { return static_cast<int>(phases.size()); }
  int num_fiducials() const { return positions_S_m.empty() ? 0 : static_cast<int>(positions_S_m.front().cols()); }

  // Empty when valid; otherwise what is wrong (at least two phases, phases
  // increasing in [0, 1), as many matrices as phases, each of the same width).
  std::string Validate() const;
};

// Reads /phases/phase [P] and /phases/fiducials_S_m [P, F, 3] of a scan file
// (scan.h5, as `dynaguide phantom` writes it).
// @throws dg::Error naming the file and dataset when one is missing or malformed.
FiducialMotion ReadFiducialMotion(const std::string& scan_h5);

// Fiducial i at a phase, interpolated linearly and cyclically between the
// scan phases (paper section 2.2: s_i(tau)). The phase may lie outside
// [0, 1): it is wrapped. Written for Ceres' Jet as well as double: the segment
// is chosen on the phase's value, the weight keeps its derivative.
// @pre motion.Validate() is empty and 0 <= fiducial < num_fiducials().
template <typename T>
void FiducialAtPhase(const FiducialMotion& motion, int fiducial, const T& phase, T* xyz_S) {
  using std::floor;
  T phi = phase - floor(phase);
  const int P = motion.num_phases();
  // The segment [phases[k], phases[k+1]] holding phi; before the first phase it
  // is the wrapping segment from the last phase.
  int k = P - 1;
  while (k >= 0 && phi < T(motion.phases[k])) --k;
  if (k < 0) {
    k = P - 1;
    phi += T(1);
  }
  const int next = (k + 1) % P;
  const double start = motion.phases[k];
  const double length = (next == 0 ? motion.phases[0] + 1.0 : motion.phases[next]) - start;
  const T w = (phi - T(start)) / T(length);
  for (int c = 0; c < 3; ++c) {
    xyz_S[c] = (T(1) - w) * T(motion.positions_S_m[k](c, fiducial)) + w * T(motion.positions_S_m[next](c, fiducial));
  }
}

}  // namespace dg::stages
