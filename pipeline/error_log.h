#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/calibration.h"
#include "io/h5_table.h"
#include "io/run_log.h"
#include "pipeline/frame_packet.h"
#include "sim/embedding.h"
#include "sim/tet_mesh.h"
#include "stages/register/fiducial_motion.h"

namespace dg::pipeline {

// The overlay's accuracy against a phantom's ground truth (paper Table 1),
// per simulated frame, into the run log's /errors (a consumer of the run-log
// sink). The truth's material points are embedded once in the scene's mesh;
// each frame they are rebuilt from the simulated nodes and brought into the
// camera by the run's own registration, so the figures hold every error of
// the system (registration, tracking, simulation), as the paper's do:
//   surface: the surface points the left camera sees, the distance in the
//            left image between where the overlay draws them and where they
//            are (px), and in mm at their depth: surface_points, then
//            surface_{mean,rms,max}_{px,mm}, and per point surface_mm (one
//            column per truth point, NaN where the left camera does not see it);
//   internal: the internal points' 3D distance to the truth (mm), per point
//            (internal_mm, one column per point) and internal_{mean,rms,max}_mm;
//   fiducials (paper Table 2): per fiducial, the 3D distance to the truth of
//            the simulation's (embedded) fiducial, fiducial_sim_mm, and of
//            the scan's own motion model (its per-phase positions
//            interpolated linearly and cyclically at the registered phase),
//            fiducial_model_mm.
//   the overlay as composed (what the surgeon sees): the ages of the layers
//            the surface and internal figures are read from (the texture
//            overlay's; the meshes', else the volume's; -1 where the frame
//            was composed without it, or the run has no such overlay),
//            surface_layer_age_frames and internal_layer_age_frames, and the
//            figures above as that layer shows them, shown_surface_*_{px,mm}
//            and shown_internal_*_mm (NaN without the layer). Every layer is
//            drawn from its own frame's state, so a composed layer's figures
//            are the state's.
// Each row also has frame and t_s. Means and RMS are over the frame's points:
// a run's figures weigh frames by their point counts (sum = mean * count).
class ErrorLog {
 public:
  // truth_h5: `dynaguide phantom`'s truth.h5. left: the left camera
  // (original pixels). scan: the scan's fiducials per phase (empty without a
  // scan). overlay_names: the run's overlays in drawing order (the order of
  // packet.layer_age_frames).
  // @throws dg::Error for a truth file without the points' datasets, or a
  // scan whose fiducials are not the truth's.
  ErrorLog(io::RunLog& log, const std::string& truth_h5, const sim::TetMesh& mesh, const io::CameraCalibration& left,
           stages::FiducialMotion scan, const std::vector<std::string>& overlay_names);

  // A frame with a simulation and a registration gets a row; others none.
  // @throws dg::Error for a frame beyond the truth's.
  void Consume(const FramePacket& packet);

 private:
  struct PointTruth {
    Eigen::Matrix3Xd reference_S;  // where the points are in the scan's reference geometry
    std::vector<double> xyz_C;     // [frame][point][xyz]
    int count = 0;
  };
  struct Truth {
    std::string path;
    int frames = 0;
    PointTruth surface, internal, fiducials;
    std::vector<double> surface_uv;             // [frame][point][uv], left image
    std::vector<std::uint8_t> surface_visible;  // [frame][point], left image
  };
  static Truth ReadTruth(const std::string& truth_h5);

  int surface_layer_, internal_layer_;  // the overlays the shown figures are read from (-1: none)
  Truth truth_;
  io::H5Table& table_;
  io::CameraCalibration left_;
  stages::FiducialMotion scan_;
  sim::Embedding surface_embedding_, internal_embedding_, fiducial_embedding_;
};

}  // namespace dg::pipeline
