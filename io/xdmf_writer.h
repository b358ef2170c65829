#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>

#include "io/mesh_fields.h"
#include "sim/tet_mesh.h"

namespace dg::io {

// How an XdmfTimeSeriesWriter lays out its files.
struct XdmfSeriesOptions {
  // Each step's grid also holds the deformed positions (reference +
  // displacement, /steps/<k>/geometry_m) and takes them as its geometry, so
  // that ParaView plays the motion as it opens the file, with no Warp By
  // Vector filter; the reference stays at /mesh/geometry_m.
  bool deformed_geometry = false;
  // true: the .xmf is rewritten after every step, so even a killed process
  // leaves every step listed. false: it is rewritten once the steps since the
  // last rewrite reach a sixteenth of those written (every step up to 31), and
  // at Close(): its rewrites cost time linear in the steps, not quadratic, for
  // a long series, and a killed process leaves the steps up to the last
  // rewrite listed (the .h5 holds every step).
  bool xmf_every_step = true;
  // The data file's name, when it is not PATH.h5 (e.g. when PATH.h5 is
  // another file); it must lie in the .xmf's directory.
  std::string h5_file_name;
};

// Writes a mesh's motion as an XDMF 3 temporal collection that ParaView opens:
// PATH.h5 holds the data, PATH.xmf describes it. The reference mesh is written
// once (/mesh/geometry_m, /mesh/topology); step k holds
// /steps/<k, 6 digits>/displacement_m and the fields under .../point/<name> and
// .../cell/<name>; /time_s lists the steps' times. After every Append the .h5
// is flushed and the .xmf rewritten (atomically; see XdmfSeriesOptions for
// the rewrites of a long series), so a run that stops early leaves readable
// files whose .xmf lists only steps the .h5 holds. The root attribute "complete" is 0 until Close(true).
// Not thread-safe: one thread appends.
class XdmfTimeSeriesWriter {
 public:
  // Creates (or truncates) PATH.h5 and PATH.xmf and writes the mesh.
  // @throws dg::Error when a file cannot be created or written.
  XdmfTimeSeriesWriter(const std::string& path, const sim::TetMesh& mesh,
                       const XdmfSeriesOptions& options = {});
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
  // early), flushes and closes the .h5, and rewrites the .xmf when it does not
  // list every step yet. Later calls do nothing.
  // @throws dg::Error when the attribute or the .xmf cannot be written.
  void Close(bool complete);

  int num_steps() const;
  const std::string& h5_path() const;
  const std::string& xmf_path() const;

 private:
  struct Impl;  // keeps HDF5's headers out of this one
  std::unique_ptr<Impl> impl_;
};

}  // namespace dg::io
