#include "tools/phantom/phantom_spec.h"

#include <cmath>

#include "sim/error.h"

namespace dg::tools::phantom {

std::string PhantomSpec::Validate() const {
  if (!(semi_axes_m.minCoeff() > 0)) return "semi-axes must be positive";
  if (!(std::abs(centre_height_m) < semi_axes_m.z())) return "the mount plane must cut the ellipsoid";
  if (tets < 100) return "--tets must be at least 100";
  if (!(heart_rate_bpm >= 20 && heart_rate_bpm <= 300)) return "--heart-rate must lie in [20, 300] bpm";
  if (!(radial_contraction >= 0 && radial_contraction < 0.5)) return "radial contraction must lie in [0, 0.5)";
  if (!(longitudinal_shortening >= 0 && longitudinal_shortening < 0.4)) {
    return "longitudinal shortening must lie in [0, 0.4)";
  }
  if (!(amplitude_variation >= 0 && amplitude_variation < 0.3 && period_variation >= 0 && period_variation < 0.3)) {
    return "cycle variations (--period-variation, --amplitude-variation) must lie in [0, 0.3)";
  }
  if (premature_beat_every < 0 || premature_beat_every == 1) {
    return "--premature-beat-every must be 0 (none) or at least 2";
  }
  if (phases < 4) return "--phases must be at least 4";
  if (ct_format != "mhd" && ct_format != "dicom" && ct_format != "both") return "--ct-format must be mhd, dicom or both";
  if (fiducials < 5) return "at least five fiducials are needed (registration uses them)";
  if (width < 64 || height < 48 || width % 2 || height % 2) return "--size must be at least 64x48, even numbers";
  if (!(fps > 0 && fps <= 240)) return "--fps must lie in (0, 240]";
  if (!(duration_s > 0)) return "--duration must be positive";
  if (video_codec != "raw" && video_codec != "huffyuv") return "--codec must be raw or huffyuv";
  if (supersample < 1 || supersample > 4) return "supersample must lie in [1, 4]";
  if (chessboard_pairs < 15) return "at least 15 chessboard pairs are needed for calibration";
  if (const std::string wrong = material.Validate(); !wrong.empty()) return wrong;
  return {};
}

PhantomSpec PresetSpec(const std::string& name) {
  PhantomSpec spec;
  spec.preset = name;
  if (name == "default") return spec;
  if (name == "tiny") {
    spec.tets = 1500;
    spec.width = 160;
    spec.height = 120;
    spec.duration_s = 1.0;
    spec.phases = 10;
    spec.voxel_m = 1.5e-3;
    return spec;
  }
  if (name == "stiff") {
    spec.material = {1.0e5, 0.49, 1.0e3};
    return spec;
  }
  if (name == "extreme") {
    spec.heart_rate_bpm = 150;
    spec.radial_contraction = 0.25;
    spec.twist_rad = 0.35;
    spec.longitudinal_shortening = 0.15;
    spec.sway_m = {0.003, 0.002};
    return spec;
  }
  throw Error("unknown phantom preset '" + name + "'", "--preset", "use default, tiny, stiff or extreme");
}

}  // namespace dg::tools::phantom
