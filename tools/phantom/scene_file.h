#pragma once

#include <string>

#include "tools/phantom/phantom_spec.h"

namespace dg::tools::phantom {

// Writes the scene's entry point, scene.yaml, naming every file of the scene
// by a path relative to it.
void WriteSceneFile(const std::string& path, const PhantomSpec& spec, int frames, double period_s);

}  // namespace dg::tools::phantom
