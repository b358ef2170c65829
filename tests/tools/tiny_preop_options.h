#pragma once

#include <filesystem>
#include <string>

#include "tests/support/tiny_phantom.h"
#include "tools/preop/preop_job.h"

namespace dg::tools::preop {

// preop on the tiny phantom's DICOM 4D CT, like its scene, 1500 tetrahedra,
// quiet: what the preop tests start from.
inline PreopOptions TinyOptions(const std::string& out_dir) {
  const std::filesystem::path phantom = testing::TinyPhantomDir();
  PreopOptions options;
  options.ct_inputs = {(phantom / "ct" / "dicom").string()};
  options.out_dir = out_dir;
  options.like_scene = (phantom / "scene.yaml").string();
  options.mesh.target_tets = 1500;
  options.progress = false;
  return options;
}

}  // namespace dg::tools::preop
