#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/mesh_fields.h"
#include "io/xdmf_writer.h"
#include "pipeline/frame_packet.h"
#include "pipeline/simulation_stages.h"

namespace dg::sim {
template <typename T>
class ForceRecovery;
}

namespace dg::pipeline {

// The simulated mesh per frame as an XDMF time series (io::XdmfTimeSeriesWriter,
// PATH.xmf + PATH.h5), a consumer of the run-log sink: one step per simulated
// frame, at the frame's video time in seconds, each holding, in the mesh's node
// order (the scene's mesh file's, less the nodes no element uses):
//   displacement_m     the simulation's node displacement, scan frame;
//   geometry_m         the deformed positions, the step's geometry (ParaView
//                      plays the motion without a filter);
//   tied               1 on the nodes tied to tracked features at that frame
//                      (constraint mapping's; imposed in surface and combined
//                      mode, measured against in volume mode), else 0;
//   recovered_force_n  with a motion model (volume and combined mode): the
//                      nodal forces the inverse simulation recovers from the
//                      scan's motion at the frame's step (paper eq. 4, from the
//                      motion one step either side), in newtons; absent in
//                      surface mode.
// The root attribute `complete` is 1 only after Finish(true). Frames before
// the registration (no simulation yet) are not in the series.
// Threading: called by the sink node, one frame at a time in frame order; the
// force recovery runs on the calling thread alone (it takes no worker from the
// graph's stages).
class MeshSeriesSink {
 public:
  // Creates PATH.xmf and PATH.h5 with the reference mesh.
  // @throws dg::Error when they cannot be created.
  MeshSeriesSink(const std::string& path, std::shared_ptr<const SimulationSetup> setup);
  ~MeshSeriesSink();
  MeshSeriesSink(const MeshSeriesSink&) = delete;
  MeshSeriesSink& operator=(const MeshSeriesSink&) = delete;

  // Appends the frame when it carries a simulation.
  // @throws dg::Error when the step cannot be written.
  void Consume(const FramePacket& packet);
  // Marks the series complete or not and closes it; the .xmf then lists every
  // frame appended. Later calls do nothing.
  // @throws dg::Error as XdmfTimeSeriesWriter::Close does.
  void Finish(bool complete);

  std::int64_t frames() const { return writer_.num_steps(); }
  const std::string& xmf_path() const { return writer_.xmf_path(); }
  const std::string& h5_path() const { return writer_.h5_path(); }

 private:
  // The recovered forces (3 x nodes) into forces_n_, at the motion's phase and rate of the frame's step.
  void RecoverForces(double phase, double rate_hz);

  std::shared_ptr<const SimulationSetup> setup_;
  io::XdmfTimeSeriesWriter writer_;
  std::unique_ptr<sim::ForceRecovery<double>> recovery_;  // null without a motion model
  // Reused from frame to frame.
  Eigen::Matrix3Xd displacement_m_;
  io::MeshFields fields_;
  std::vector<double> motion_m_[3], forces_n_;
};

}  // namespace dg::pipeline
