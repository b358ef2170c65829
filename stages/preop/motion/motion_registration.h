#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/ct/ct_image.h"

namespace dg::stages::preop {

// The image similarity the registration optimises.
enum class MotionMetric {
  kMeanSquares,        // mean squared HU difference: CT numbers are absolute, so one tissue has one value in every phase
  kMutualInformation,  // minus Mattes' mutual information: tolerates HU that change between phases (contrast agent)
};

// How each phase is registered to the first (paper section 2.4): a cubic
// tensor-product B-spline free-form deformation, fitted coarse to fine.
//
// Regularisation is the control-point grid itself: the finest spacing bounds
// how fast the deformation may vary, and each coarser level doubles it. Inside
// an organ of uniform HU the images only constrain the motion at boundaries
// (surface, chambers, beads); a grid much coarser than the voxels carries the
// displacement smoothly between them (cubic B-splines are C2), with no
// penalty weight to tune against the metric's HU scale.
struct MotionRegistrationOptions {
  double grid_spacing_mm = 16.0;  // control-point spacing at the finest level
  int levels = 3;                 // level l of L: image shrunk 2^(L-1-l), control points 2^(L-1-l) times as far apart
  int max_iterations = 30;        // L-BFGS iterations per level
  MotionMetric metric = MotionMetric::kMeanSquares;
  double bending_weight = 0;      // HU^2 per mm^2 of the control points' mean squared second difference (mean squares only)
  // The finest level compares every voxel along an axis whose voxels are at
  // least this far apart, and every second (third, ...) voxel along finer
  // axes, after a blur of half that step. A control grid of 16 mm is fitted
  // as well from samples 3 mm apart (over 100 to a control point's cell) as
  // from every voxel of a fine scan, at a fraction of the cost, and the blur
  // keeps the metric from fitting noise (docs/preop.md, "Where and how densely").
  double finest_sample_mm = 3.0;
  // Where the motion is wanted (S, metres; both or neither): the phases are
  // registered on phase 0's voxels within this box grown by two finest
  // control-point spacings on each side (docs/preop.md, "Where and how densely"), so the cost
  // follows the organ, not the scanner's field of view. Unset: the whole grid.
  std::optional<Eigen::Vector3d> region_min_S_m, region_max_S_m;

  std::string Validate() const;  // empty when valid
};

// The part of phase 0's grid the registration works on and its deformation
// is defined over: the voxels of options' region grown by its margin, at
// least 4 along each axis; the whole grid without a region. No values.
// @throws dg::Error when the region misses the grid.
io::CtImage RegistrationGrid(const io::CtImage& phase0, const MotionRegistrationOptions& options);

// Figures of one phase's registration, for a report.
struct PhaseRegistrationReport {
  int phase = 0;
  double metric_before = 0;  // the finest level's objective (MotionMetric, HU^2 or nats, plus any bending term) at the identity
  double metric_after = 0;   // and at the result
  int iterations = 0;        // L-BFGS iterations, all levels
  int evaluations = 0;       // of the metric and its gradient, all levels (line searches included)
  double min_jacobian = 1;   // det of the deformation's Jacobian over the finest level's samples
  double max_jacobian = 1;
  double wall_s = 0;
  std::string stop_condition;  // the optimiser's, at the finest level
};

// The deformation from phase 0 to one phase: maps a point at its phase-0
// position (scan frame S, metres) to its position in that phase. Immutable and
// cheap to copy (the B-spline is shared); safe to use from several threads.
class PhaseDeformation {
 public:
  // The identity (phase 0).
  PhaseDeformation();

  // x_k(X) - X for each column X (phase-0 positions). Zero for the identity.
  // @throws dg::Error naming the first point outside the phase-0 image's grid,
  //         where the deformation is not defined.
  Eigen::Matrix3Xd Displacements(const Eigen::Matrix3Xd& points_S_m) const;

  const PhaseRegistrationReport& report() const { return report_; }

  // The fitted B-spline as numbers (ITK's fixed parameters: its grid; and its
  // parameters: the control points' displacements, mm), to keep a
  // registration between runs. Both empty for the identity.
  std::vector<double> FixedParameters() const;
  std::vector<double> Parameters() const;
  // The deformation those numbers describe over `grid` (phase 0's geometry).
  // @throws dg::Error when the numbers do not make a B-spline of this order.
  static PhaseDeformation FromParameters(const std::vector<double>& fixed_parameters,
                                         const std::vector<double>& parameters, const io::CtImage& grid,
                                         PhaseRegistrationReport report);

  struct Spline;  // the fitted B-spline (ITK's), defined in the .cc
  PhaseDeformation(std::shared_ptr<const Spline> spline, PhaseRegistrationReport report);

 private:
  std::shared_ptr<const Spline> spline_;  // null: the identity
  PhaseRegistrationReport report_;
};

// @throws dg::Error for fewer than two phases, a phase whose grid (size,
//         spacing, origin, direction) differs from phase 0, or a phase whose
//         values do not fill its grid; each names the phase and its source.
void CheckPhases(const std::vector<io::CtImage>& phases);

// The registration of each phase (moving) to phase 0 (fixed). Phase 0's
// blurred samples for every level are made once, here, and shared by the
// registrations of all phases.
class PhaseRegistration {
 public:
  // Keeps a reference to phases, which must outlive it.
  // @throws dg::Error on invalid options or phases CheckPhases refuses.
  PhaseRegistration(const std::vector<io::CtImage>& phases, const MotionRegistrationOptions& options);
  ~PhaseRegistration();
  PhaseRegistration(const PhaseRegistration&) = delete;
  PhaseRegistration& operator=(const PhaseRegistration&) = delete;

  // Phase k registered on the calling thread: the deformation maps phase-0
  // positions to phase k. Calls for different phases may run at once (each
  // makes its own moving images, and the optimiser keeps no state between
  // calls); the result does not depend on it, to the bit.
  // @throws dg::Error for k outside 1 to phases.size() - 1, or ITK failing on
  //         the phase.
  PhaseDeformation Register(int k) const;

 private:
  struct Levels;
  const std::vector<io::CtImage>& phases_;
  MotionRegistrationOptions options_;
  std::unique_ptr<const Levels> levels_;
};

// Every phase registered in turn: result k from PhaseRegistration's
// Register(k), result 0 the identity.
// @throws as PhaseRegistration.
std::vector<PhaseDeformation> RegisterPhases(const std::vector<io::CtImage>& phases,
                                             const MotionRegistrationOptions& options);

// The registration's view of a CT phase as the moving image: its cubic
// B-spline interpolant (ITK's prefilter, mirror boundaries), with the
// gradient. Interpolates the voxels and reproduces cubic polynomials away
// from the border.
struct CtSamples {
  Eigen::VectorXd values_hu;           // NaN where outside
  Eigen::Matrix3Xd gradients_hu_per_m;  // along S's axes
  std::vector<bool> inside;             // within half a voxel of the outer voxels' centres
};
// @throws dg::Error for fewer than 4 voxels along an axis, or values that do
//         not fill the grid.
CtSamples SampleCubic(const io::CtImage& ct, const Eigen::Matrix3Xd& points_S_m);

// The array scan.h5 holds as /phases/node_displacement_m: shape [P, N, 3],
// row-major (phase, node, xyz), metres; phase p's row is
// deformations[p].Displacements(nodes_S_m).
std::vector<double> NodeDisplacementArray(const std::vector<PhaseDeformation>& deformations,
                                          const Eigen::Matrix3Xd& nodes_S_m);

}  // namespace dg::stages::preop
