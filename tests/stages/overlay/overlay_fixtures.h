#pragma once

#include <Eigen/Geometry>

#include "io/calibration.h"
#include "sim/tet_mesh.h"

namespace dg::stages::overlay::testing {

// A distortion-free camera of width x height pixels, focal length f pixels, centred principal point.
inline io::CameraCalibration PinholeCalibration(int width, int height, double f) {
  io::CameraCalibration camera;
  camera.K << f, 0, (width - 1) / 2.0, 0, f, (height - 1) / 2.0, 0, 0, 1;
  camera.width = width;
  camera.height = height;
  return camera;
}

// One large tetrahedron around the view axis, z from 5 to 25 cm: surfaces drawn
// in the tests are embedded in (or extrapolated from) it.
inline sim::TetMesh OneTet() {
  sim::TetMesh mesh;
  mesh.X_m.resize(3, 4);
  mesh.X_m << -0.2, 0.2, 0.0, 0.0,  //
      -0.15, -0.15, 0.25, 0.0,      //
      0.05, 0.05, 0.05, 0.25;
  mesh.tets.resize(4, 1);
  mesh.tets << 0, 1, 2, 3;
  sim::OrientElements(&mesh);
  mesh.source = "one tetrahedron";
  return mesh;
}

}  // namespace dg::stages::overlay::testing
