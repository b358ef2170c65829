#pragma once

#include <string>
#include <vector>

#include "io/gmsh_module/interface.h"

namespace dg::io::gmsh_module {

// Adds `solid` to Gmsh's current model, synchronised, with its physical
// groups: a box's faces "xmin" ... "zmax", an ellipsoid's "surface", a
// truncated ellipsoid's "surface" and "base" (its face on z = 0), and the
// volume "body"; a closed surface gets none (the program names its nodes).
// A closed surface is first split into patches Gmsh can reparametrise, so the
// volume can be remeshed at any size. Calls Gmsh: run it inside Session::Run.
void AddSolid(const Solid& solid);

// Adds the physical group `name` of the entities `tags` of dimension `dim`.
void AddPhysicalGroup(int dim, const std::vector<int>& tags, const std::string& name);

}  // namespace dg::io::gmsh_module
