#include "tests/stages/preop/segment/phantom_phase0.h"

#include <cstdint>
#include <filesystem>

#include "io/metaimage.h"
#include "stages/preop/segment/surface_extraction.h"
#include "tools/phantom/phantom_cache.h"

namespace dg::testing {

const PhantomPhase0& DefaultPhantomPhase0() {
  static const PhantomPhase0 phase0 = [] {
    PhantomPhase0 p;
    p.dir = std::filesystem::path(tools::DefaultScenePath(false)).parent_path().string();
    const std::string mhd = p.dir + "/ct/phase_00.mhd";
    p.ct = io::ToCtImage(io::ReadMetaImage<std::int16_t>(mhd), mhd);
    p.segmentation = stages::preop::Segment(p.ct, stages::preop::SegmentationOptions{});
    p.organ_surface = stages::preop::ExtractSurface(p.segmentation.organ, stages::preop::SurfaceOptions{});
    return p;
  }();
  return phase0;
}

}  // namespace dg::testing
