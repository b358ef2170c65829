#include "stages/register/fiducial_motion.h"

#include "io/h5_file.h"
#include "sim/error.h"

namespace dg::stages {

std::string FiducialMotion::Validate() const {
  if (phases.size() < 2) return "at least two scan phases are needed";
  if (positions_S_m.size() != phases.size()) {
    return std::to_string(phases.size()) + " phases but " + std::to_string(positions_S_m.size()) + " position sets";
  }
  for (size_t k = 0; k < phases.size(); ++k) {
    if (!(phases[k] >= 0 && phases[k] < 1)) return "phase " + std::to_string(k) + " is outside [0, 1)";
    if (k > 0 && !(phases[k] > phases[k - 1])) return "the phases do not increase at phase " + std::to_string(k);
    if (positions_S_m[k].cols() != positions_S_m[0].cols()) {
      return "phase " + std::to_string(k) + " has " + std::to_string(positions_S_m[k].cols()) + " fiducials, phase 0 " +
             std::to_string(positions_S_m[0].cols());
    }
    if (!positions_S_m[k].allFinite()) return "phase " + std::to_string(k) + " has a position that is not finite";
  }
  return {};
}

FiducialMotion ReadFiducialMotion(const std::string& scan_h5) {
  const io::H5Reader file(scan_h5);
  FiducialMotion motion;
  io::H5Shape shape;
  motion.phases = file.Read<double>("/phases/phase");
  if (!file.Has("/phases/fiducials_S_m")) {
    throw Error("the scan has no fiducials (/phases/fiducials_S_m): none was found in its CT", scan_h5,
                "mark the fiducials at the CT's first phase (3D Slicer markups) and run `dynaguide preop` again with "
                "--fiducials FILE --resume");
  }
  const std::vector<double> xyz = file.Read<double>("/phases/fiducials_S_m", &shape);
  if (shape.size() != 3 || shape[2] != 3 || shape[0] != motion.phases.size()) {
    throw Error("/phases/fiducials_S_m must have the shape [phases, fiducials, 3] with one row per /phases/phase entry",
                scan_h5, "write the fiducials' scan positions per phase, as dynaguide phantom does");
  }
  const Eigen::Index F = static_cast<Eigen::Index>(shape[1]);
  for (size_t k = 0; k < shape[0]; ++k) {
    motion.positions_S_m.push_back(Eigen::Map<const Eigen::Matrix3Xd>(xyz.data() + k * F * 3, 3, F));
  }
  if (const std::string wrong = motion.Validate(); !wrong.empty()) {
    throw Error("invalid fiducial motion: " + wrong, scan_h5 + ":/phases", "check the scan file's phases");
  }
  return motion;
}

}  // namespace dg::stages
