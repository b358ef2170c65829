#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>

#include "io/mesh_fields.h"
#include "sim/tet_mesh.h"

namespace dg::io {

// Writes a mesh's motion as an XDMF 3 temporal collection that ParaView opens:
// PATH.h5 holds the data, PATH.xmf describes it. The reference mesh is written
// once (/mesh/geometry_m, /mesh/topology); step k holds
// /steps/<k, 6 digits>/displacement_m and the fields under .../point/<name> and
// .../cell/<name>; /time_s lists the steps' times. After every Append the .h5
// is flushed and the .xmf rewritten (atomically), so a run that stops early
// leaves readable files. The root attribute "complete" is 0 until Close(true).
// Not thread-safe: one thread appends.
class XdmfTimeSeriesWriter {
 public:
  // Creates (or truncates) PATH.h5 and PATH.xmf and writes the mesh.
  // @throws dg::Error when a file cannot be created or written.
  XdmfTimeSeriesWriter(const std::string& path, const sim::TetMesh& mesh);
  // Closes with complete = 0 unless Close() was called.
  ~XdmfTimeSeriesWriter();
  XdmfTimeSeriesWriter(const XdmfTimeSeriesWriter&) = delete;
  XdmfTimeSeriesWriter& operator=(const XdmfTimeSeriesWriter&) = delete;

  // Adds the step at time t_s, which must be finite and after the previous step's.
  // @pre Close() has not been called.
  // @throws dg::Error on a bad time, a displacement without one column per node,
  //   a misnamed or wrongly sized field (CheckMeshFields), or a failed write.
  void Append(double t_s, const Eigen::Matrix3Xd& displacement_m, const MeshFields& fields);

  // Writes the root attribute complete = 1 (or 0, for a run that stopped
  // early), flushes and closes the files. Later calls do nothing.
  // @throws dg::Error when the attribute cannot be written.
  void Close(bool complete);

  int num_steps() const;

 private:
  struct Impl;  // keeps HDF5's headers out of this one
  std::unique_ptr<Impl> impl_;
};

}  // namespace dg::io
