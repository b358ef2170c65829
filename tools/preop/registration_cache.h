#pragma once

#include <optional>
#include <string>
#include <vector>

#include "io/ct/ct_image.h"
#include "stages/preop/motion/motion_registration.h"

namespace dg::tools::preop {

// Each phase's motion registration kept in `folder` (preop's --out/cache/),
// one HDF5 file a phase, so that a rerun after a late failure or with other
// mesh options does not register the phases again (docs/commands/preop.md,
// --resume). An entry is used only when it was made from the same phase-0
// and phase-k voxels (geometry and a hash of the values) with the same
// registration options; anything else is registered again.
class RegistrationCache {
 public:
  RegistrationCache(std::string folder, const std::vector<io::CtImage>& phases,
                    const stages::preop::MotionRegistrationOptions& options);

  // Phase k's registration when the cache holds one made from these inputs.
  std::optional<stages::preop::PhaseDeformation> Load(int k) const;
  // Keeps phase k's registration; safe to call from several threads at once.
  // @throws dg::Error when the file cannot be written.
  void Save(int k, const stages::preop::PhaseDeformation& deformation) const;

 private:
  std::string PathOf(int k) const;
  std::string KeyOf(int k) const;

  std::string folder_;
  io::CtImage grid_;  // the registration's (RegistrationGrid), no values
  std::string options_text_;
  std::vector<std::string> phase_hashes_;
};

}  // namespace dg::tools::preop
