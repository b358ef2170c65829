// `dynaguide preop`: a 4D CT to a scene's preoperative part.
#include <cstdio>
#include <optional>

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include "sim/error.h"
#include "tools/commands.h"
#include "stages/preop/segment/segmentation_presets.h"
#include "tools/preop/preop_job.h"

namespace dg::tools {
namespace {

struct PreopArguments {
  preop::PreopOptions options;
  std::vector<double> organ_hu, internal_hu, mount_hu, bead_size_mm, roi_mm, seed_point_mm, intensity_scale;
  std::string preset;
  std::optional<int> max_internal;
  bool not_hu = false;
  int threads = 0;
  bool quiet = false;
};

stages::preop::HuRange Range(const std::vector<double>& bounds, stages::preop::HuRange fallback) {
  return bounds.empty() ? fallback : stages::preop::HuRange{bounds[0], bounds[1]};
}

void RunPreopCommand(PreopArguments& args) {
  preop::PreopOptions& options = args.options;
  if (!args.preset.empty()) {
    // The label-map options are not the preset's: keep what was given.
    const stages::preop::SegmentationOptions given = options.segmentation;
    options.segmentation = stages::preop::SegmentationPreset(args.preset);
    options.segmentation.organ_label = given.organ_label;
    options.segmentation.mount_label = given.mount_label;
    options.segmentation.internal_labels = given.internal_labels;
  }
  if (args.max_internal) options.segmentation.max_internal_structures = *args.max_internal;
  if (args.not_hu && !args.intensity_scale.empty()) {
    throw Error("--not-hu and --intensity-scale both given", "dynaguide preop",
                "give --intensity-scale when you know how the values map to HU, else --not-hu with --labels");
  }
  if (args.not_hu) options.intensity = io::CtIntensity::kNotHu;
  if (!args.intensity_scale.empty()) {
    options.intensity = io::CtIntensity::kScale;
    options.intensity_slope = args.intensity_scale[0];
    options.intensity_intercept = args.intensity_scale[1];
  }
  if (!args.seed_point_mm.empty()) {
    options.segmentation.seed_point_m =
        1e-3 * Eigen::Vector3d(args.seed_point_mm[0], args.seed_point_mm[1], args.seed_point_mm[2]);
  }
  options.segmentation.organ_hu = Range(args.organ_hu, options.segmentation.organ_hu);
  options.segmentation.internal_hu = Range(args.internal_hu, options.segmentation.internal_hu);
  options.segmentation.mount_hu = Range(args.mount_hu, options.segmentation.mount_hu);
  if (!args.bead_size_mm.empty()) {
    options.beads.min_diameter_mm = args.bead_size_mm[0];
    options.beads.max_diameter_mm = args.bead_size_mm[1];
  }
  if (!args.roi_mm.empty()) {
    options.beads.roi_min_m = 1e-3 * Eigen::Vector3d(args.roi_mm[0], args.roi_mm[1], args.roi_mm[2]);
    options.beads.roi_max_m = 1e-3 * Eigen::Vector3d(args.roi_mm[3], args.roi_mm[4], args.roi_mm[5]);
    if (!options.beads.HasRoi()) {
      throw Error("--roi must be XMIN YMIN ZMIN XMAX YMAX ZMAX with each min at most its max", "--roi",
                  "give the box's two corners in mm, in the CT's LPS frame (as 3D Slicer shows it with LPS)");
    }
    options.segmentation.roi_min_m = options.beads.roi_min_m;
    options.segmentation.roi_max_m = options.beads.roi_max_m;
  }
  options.progress = !args.quiet;
  const int threads = args.threads > 0 ? args.threads : tbb::info::default_concurrency();
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
  options.threads = threads;
  const preop::PreopSummary summary = preop::RunPreop(options);
  std::fputs(summary.Describe().c_str(), stdout);
  std::printf("written to %s (report: preop.json%s)\n", options.out_dir.c_str(),
              options.like_scene.empty() ? "" : ", scene: scene.yaml");
}

}  // namespace

void AddPreopCommand(CLI::App& app) {
  auto args = std::make_shared<PreopArguments>();
  preop::PreopOptions& o = args->options;
  CLI::App* command = app.add_subcommand(
      "preop", "A 4D CT to a scene's preoperative part: mesh.msh, scan.h5 (the motion), overlay assets");
  command->add_option("ct", o.ct_inputs,
                      "The 4D CT: one DICOM folder holding every phase's series, one folder per phase, or one "
                      "image file per phase (.nii, .nii.gz, .nrrd, .mhd, .mha) in cycle order")
      ->required();
  command->add_option("--out", o.out_dir, "Output directory (created)")->required();
  command->add_option("--series", o.series_uids, "Phases by SeriesInstanceUID, in cycle order");
  command->add_option("--like", o.like_scene,
                      "A scene whose video, calibration, truth and run settings the written scene.yaml takes");
  command->add_option("--period-s", o.period_s, "The CT's cycle, seconds: a heartbeat or a breath (default: the --like scene's)");
  command->add_option("--labels", o.label_map,
                      "A label map on phase 0's grid (3D Slicer, ITK-SNAP) instead of automatic segmentation");
  command->add_option("--organ-label", o.segmentation.organ_label, "The organ's label in --labels")->capture_default_str();
  command->add_option("--mount-label", o.segmentation.mount_label, "The mount's label in --labels (0: none)")
      ->capture_default_str();
  command->add_option("--internal-labels", o.segmentation.internal_labels,
                      "Internal structures' labels in --labels, each one embedded mesh");
  command->add_option("--preset", args->preset,
                      "Automatic segmentation's settings for the scan: phantom (default), cardiac-contrast, chest, "
                      "abdomen, liver, lung; --organ-hu, --internal-hu and --mount-hu override its ranges")
      ->check(CLI::IsMember(stages::preop::SegmentationPresetNames()));
  command->add_option("--seed-point", args->seed_point_mm,
                      "Automatic: a point inside the organ, X Y Z mm in the CT's frame (LPS); its component is the "
                      "organ instead of the largest one")
      ->expected(3)
      ->delimiter(',');
  command->add_option("--max-internal", args->max_internal,
                      "Automatic: internal structures kept, largest first (default: the preset's; phantom 8)");
  command->add_option("--intensity-scale", args->intensity_scale,
                      "The CT's values are not HU: SLOPE INTERCEPT (or SLOPE,INTERCEPT) such that HU = SLOPE * value + "
                      "INTERCEPT")
      ->expected(2)
      ->delimiter(',');
  command->add_flag("--not-hu", args->not_hu,
                    "Take the CT's values as stored, unchecked (an image that is not CT in HU); automatic "
                    "segmentation then needs HU and is refused: give --labels");
  command->add_option("--organ-hu", args->organ_hu,
                      "Automatic: the organ's HU range MIN MAX (default: the preset's; phantom -480 375)")
      ->expected(2);
  command->add_option("--internal-hu", args->internal_hu,
                      "Automatic: internal structures' HU range MIN MAX (default: the preset's; phantom 145 375)")
      ->expected(2);
  command->add_option("--mount-hu", args->mount_hu,
                      "Automatic: the mount's HU range MIN MAX (default: the preset's; phantom 375 1750)")
      ->expected(2);
  command->add_option("--roi", args->roi_mm,
                      "A box in the CT's frame (LPS, mm): XMIN YMIN ZMIN XMAX YMAX ZMAX; beads and the organ are "
                      "looked for only inside it")
      ->expected(6)
      ->delimiter(',');
  command->add_option("--fiducials", o.fiducials_file,
                      "The fiducials at phase 0 from a file instead of beads found in the CT: 3D Slicer markups "
                      "(.mrk.json, .fcsv; LPS or RAS as stated in the file) or x,y,z in mm, LPS (.csv)");
  command->add_option("--bead-min-hu", o.beads.threshold_hu, "Fiducial beads: voxels above this CT number")
      ->capture_default_str();
  command->add_option("--bead-size-mm", args->bead_size_mm,
                      "Fiducial beads: MIN MAX diameter, mm, of a sphere of a bead's volume (default 0 6)")
      ->expected(2)
      ->delimiter(',');
  command->add_flag("--register-organ-box", o.register_organ_box,
                    "Register the motion on the box of the mesh and fiducials (grown by two control spacings) rather "
                    "than the whole scan: faster when the scan is much larger than the organ; where the organ is cut "
                    "by the scan's edge its nodes there can come out worse");
  command->add_flag("--resume", o.resume,
                    "Take each phase's registration from --out's cache/ when it was made from the same CT and "
                    "registration options (after a failure late in the run, or to mesh again)");
  command->add_option("--tets", o.mesh.target_tets, "Target tetrahedron count")->capture_default_str();
  command->add_option("--triangles", o.surface.target_triangles, "Decimated surface's triangle count")
      ->capture_default_str();
  command->add_option("--smoothing-voxels", o.surface.image_smoothing_sigma_voxels,
                      "Gaussian blur of the organ's mask before its surface is extracted, voxels (standard deviation); "
                      "more is tried by itself when the surface cannot be meshed")
      ->capture_default_str();
  command->add_option("--grid-mm", o.motion.grid_spacing_mm, "B-spline control-point spacing at the finest level, mm")
      ->capture_default_str();
  command->add_option("--levels", o.motion.levels, "B-spline registration levels, coarse to fine")->capture_default_str();
  command->add_option("--sample-mm", o.motion.finest_sample_mm,
                      "B-spline registration: the finest level compares voxels about this far apart at least (every "
                      "second or third voxel of a finer scan, after a blur of half that step), mm")
      ->capture_default_str();
  command->add_option("--iterations", o.motion.max_iterations, "B-spline registration: L-BFGS iterations per level")
      ->capture_default_str();
  command->add_option("--bending-weight", o.motion.bending_weight,
                      "B-spline bending penalty, HU^2 per mm^2 of the control points' mean squared second difference")
      ->capture_default_str();
  command->add_option("--annotation", o.annotation,
                      "An image laid on the organ's surface for the texture overlay (projected along z)");
  command->add_option("--threads", args->threads, "Worker threads (default: all cores)")->check(CLI::PositiveNumber);
  command->add_flag("--quiet", args->quiet, "No progress lines");
  command->callback([args] { RunPreopCommand(*args); });
}

}  // namespace dg::tools
