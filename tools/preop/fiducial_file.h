#pragma once

#include <string>

#include <Eigen/Core>

namespace dg::tools::preop {

// Fiducial positions at the CT's first phase, in the scan frame S (LPS,
// metres), read from what users mark them with (docs/preop.md, "Fiducials"):
//  - a 3D Slicer markups file (.mrk.json): every control point of the first
//    markup, in its coordinateSystem (LPS or RAS) and coordinateUnits (mm);
//  - a 3D Slicer fiducial list (.fcsv): the "# CoordinateSystem" header line
//    (LPS, RAS, or the older 0 = RAS, 1 = LPS; RAS when absent, as Slicer
//    reads it) and columns id,x,y,z,...;
//  - a CSV file (.csv): x,y,z in mm, LPS, one point a line, with or without a
//    header line (a line whose first three fields are not numbers).
// @throws dg::Error naming the file (and line) for an unknown extension, a
//   coordinate system or unit not stated as above, a malformed line, or no point.
Eigen::Matrix3Xd ReadFiducialFile(const std::string& path);

}  // namespace dg::tools::preop
