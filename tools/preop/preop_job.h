#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/ct/ct_reader.h"
#include "stages/preop/motion/motion_registration.h"
#include "stages/preop/segment/segmentation.h"
#include "stages/preop/segment/surface_extraction.h"
#include "stages/preop/segment/tetrahedralisation.h"
#include "sim/material.h"
#include "sim/tet_mesh.h"
#include "stages/register/bead_detection.h"

namespace dg::tools::preop {

// `dynaguide preop`: a 4D CT to a scene's preoperative part (paper section
// 2.4; docs/preop.md). Each step is library code (io/ct, stages/preop); this
// job runs them in order, times them and writes the outputs.
struct PreopOptions {
  std::vector<std::string> ct_inputs;  // a DICOM folder of every phase, a folder per phase, or a file per phase
  std::vector<std::string> series_uids;  // phases chosen by SeriesInstanceUID, in cycle order
  io::CtIntensity intensity = io::CtIntensity::kHu;  // what the CT's values are (io::CtReadOptions)
  double intensity_slope = 1, intensity_intercept = 0;  // with kScale: HU = slope * value + intercept
  std::string out_dir;
  std::string label_map;      // a segmentation on phase 0's grid; empty: automatic
  std::string annotation;     // an image laid on the organ's surface for the texture overlay; empty: none
  std::string like_scene;     // a scene whose video, calibration, truth and run settings scene.yaml takes
  double period_s = 0;        // the CT's cardiac or breathing period; 0: the like scene's
  // The fiducials at phase 0 from a 3D Slicer markups file (.mrk.json, .fcsv)
  // or a CSV file (ReadFiducialFile), instead of beads found in the CT; their
  // motion is then the registered motion.
  std::string fiducials_file;
  stages::BeadDetectionOptions beads;
  // Register on the box of the mesh and fiducials grown by two control
  // spacings (faster on a scan much larger than the organ) rather than on the
  // whole scan; docs/preop.md, "Where and how densely", gives the trade-off.
  bool register_organ_box = false;
  bool resume = false;        // take each phase's registration from --out/cache/ when made from the same inputs
  stages::preop::SegmentationOptions segmentation;
  stages::preop::SurfaceOptions surface;
  stages::preop::TetrahedralisationOptions mesh;
  stages::preop::MotionRegistrationOptions motion;
  int threads = 0;            // phases registered at once, each on one core; 0: TBB's default
  bool progress = true;       // a line per step and per phase on stderr
  std::string Validate() const;  // empty when valid
};

// One step's wall time, for the report.
struct StepTime {
  std::string step;
  double wall_s = 0;
};

// Per fiducial, the distance between its B-spline-deformed phase-0 position
// and where the bead was found in each phase (the paper's Table 2, first row).
struct FiducialErrors {
  Eigen::MatrixXd error_m;  // [phases, fiducials]
  double mean_m() const { return error_m.size() ? error_m.mean() : 0; }
};

// Where the scan's fiducials came from.
enum class FiducialSource { kNone, kBeads, kFile };

// The mesh's explicit stability limit at the material and time step it will
// be simulated with (the like scene's, else the defaults).
struct MeshStability {
  double dt_critical_s = 0;  // assembled, sim::EstimateStability
  double dt_s = 0;           // the scene's time step
  double safety = 0;         // the fraction of dt_critical_s a step may take (sim::DefaultStabilitySafety)
  std::string limit;         // where the limit is set (sim::StabilityReport::Describe)
  std::string excess;        // empty when dt_s <= safety * dt_critical_s, else what `run` would refuse
};

// The stability limit `dynaguide run` checks a scene's mesh against (its
// base nodes fixed), at a material and time step.
// @throws dg::Error for an invalid material or mesh.
MeshStability EstimateMeshStability(const sim::TetMesh& mesh, const sim::Material& material, double dt_s);

// The balls (radius, mm) the organ's mask is closed by in turn when its
// surface has tunnels that blurring does not close.
inline constexpr double kTunnelClosings_mm[] = {8.0, 12.0, 16.0};

// The extra blurs of the organ's mask, in voxels beyond the last surface's,
// tried in turn when Gmsh cannot mesh a surface or reach the radius ratio
// (stages::preop::UnmeshableSurface).
inline constexpr double kExtraSmoothingVoxels[] = {1.0, 2.0};

// Meshings at fewer tetrahedra tried when the first mesh's stable step is
// under the scene's.
inline constexpr int kStabilityRemeshings = 3;

// The organ's mesh for a scene simulated at this material and time step
// (docs/preop.md, "The mesh's stability limit"): stages::preop::Tetrahedralise,
// and when its stable step is under dt_s, meshed again at fewer tetrahedra
// (the count scaled by the cube of the shortfall, at least 10% fewer), up to
// kStabilityRemeshings times, keeping the most stable. `stability` says the
// limit of the mesh returned; its `excess` is not empty when even that one is
// under dt_s.
// @throws dg::Error as Tetrahedralise.
sim::TetMesh MeshForScene(const io::SurfaceMesh& surface, const stages::preop::VoxelMask& mount,
                          stages::preop::TetrahedralisationOptions options, const sim::Material& material, double dt_s,
                          stages::preop::TetrahedralisationReport* report, MeshStability* stability);

struct PreopSummary {
  int phases = 0;
  Eigen::Vector3i ct_size = Eigen::Vector3i::Zero();
  Eigen::Vector3d ct_spacing_m = Eigen::Vector3d::Zero();
  std::string ct_reoriented_from;  // io::CtImage::reoriented_from of the phases: "" when on S's axes as read
  stages::preop::SegmentationReport segmentation;
  stages::preop::SurfaceReport surface;
  double tunnel_closing_mm = 0;  // the ball the organ's mask was closed by to fill tunnels; 0: none
  stages::preop::TetrahedralisationReport mesh;
  std::vector<stages::preop::PhaseRegistrationReport> registration;
  MeshStability stability;
  FiducialSource fiducial_source = FiducialSource::kNone;
  int fiducial_count = 0;
  FiducialErrors fiducials;  // beads only: a file's fiducials move with the registration by definition
  int phases_from_cache = 0;
  std::vector<StepTime> steps;
  double wall_s = 0;
  double peak_rss_gb = 0;
  std::string Describe() const;  // the command's closing lines
};

// Runs every step and writes into options.out_dir (created): mesh.msh,
// scan.h5, ct/phase_NN.mhd, assets/, cache/ (each phase's registration),
// preop.json, and scene.yaml with a like scene. The cheap steps and every
// check come first (reading, segmentation, mesh, its quality and stability,
// the fiducials), the registrations last. preop.json is written first marked
// incomplete and rewritten complete at the end, so a run stopped by an error
// leaves that mark and the error.
// @throws dg::Error for invalid options and from every step.
PreopSummary RunPreop(const PreopOptions& options);

}  // namespace dg::tools::preop
