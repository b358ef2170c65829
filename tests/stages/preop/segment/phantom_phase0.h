#pragma once

#include <string>

#include "io/ct/ct_image.h"
#include "io/surface_mesh.h"
#include "stages/preop/segment/segmentation.h"

namespace dg::testing {

// Phase 0 of the default phantom's CT (tools/phantom, generated into the
// cache on first use) segmented with the default options and its organ's
// surface extracted with the default options: computed once per test process.
struct PhantomPhase0 {
  std::string dir;  // the phantom scene's folder: mesh.msh, assets/
  io::CtImage ct;
  stages::preop::Segmentation segmentation;
  io::SurfaceMesh organ_surface;
};
const PhantomPhase0& DefaultPhantomPhase0();

}  // namespace dg::testing
