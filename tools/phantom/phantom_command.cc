// `dynaguide phantom`: a beating-heart phantom scene with exact ground truth.
#include <cstdio>
#include <regex>

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include "sim/error.h"
#include "tools/commands.h"
#include "tools/phantom/beat_options.h"
#include "tools/phantom/phantom_generator.h"
#include "tools/phantom/phantom_spec.h"
#include "tools/phantom/real_ct_phantom.h"

namespace dg::tools {
namespace {

struct PhantomArguments {
  std::string out_dir;
  std::string preset = "default";
  uint64_t seed = 1;
  double heart_rate_bpm = 0, duration_s = 0, fps = 0;
  int phases = 0, tets = 0, threads = 0, fiducials = 0;
  double baseline_m = 0, distance_m = 0, noise = -1, voxel_m = 0;
  std::string size, codec, ct_format;
  phantom::BeatOptions beat;
  bool quiet = false;
  // A phantom from a real CT (--ct): phantom::RealCtPhantomOptions.
  std::string ct, labels, motion = "cardiac";
  int organ_label = 0;
  double amplitude_mm = 4, period_s = 0;
};

// `--ct`: the real CT warped by a known motion (docs/commands/phantom.md, "A phantom from a real CT").
void RunRealCtPhantom(const PhantomArguments& args) {
  phantom::RealCtPhantomOptions options;
  options.ct = args.ct;
  options.labels = args.labels;
  options.organ_label = args.organ_label;
  options.out_dir = args.out_dir;
  options.motion = args.motion == "respiratory" ? phantom::RealCtMotion::Kind::kRespiratory
                                                : phantom::RealCtMotion::Kind::kCardiac;
  if (args.phases > 0) options.phases = args.phases;
  options.amplitude_mm = args.amplitude_mm;
  options.period_s = args.period_s;
  options.seed = args.seed;
  if (!args.ct_format.empty()) options.ct_format = args.ct_format;
  options.progress = !args.quiet;
  const phantom::RealCtPhantomSummary summary = phantom::GenerateRealCtPhantom(options);
  std::fputs(summary.Describe().c_str(), stdout);
}

void RunPhantomCommand(const PhantomArguments& args) {
  const int threads = args.threads > 0 ? args.threads : tbb::info::default_concurrency();
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
  if (!args.ct.empty()) return RunRealCtPhantom(args);
  phantom::PhantomSpec spec = phantom::PresetSpec(args.preset);
  spec.seed = args.seed;
  if (args.heart_rate_bpm > 0) spec.heart_rate_bpm = args.heart_rate_bpm;
  if (args.duration_s > 0) spec.duration_s = args.duration_s;
  if (args.fps > 0) spec.fps = args.fps;
  if (args.phases > 0) spec.phases = args.phases;
  if (args.tets > 0) spec.tets = args.tets;
  if (args.fiducials > 0) spec.fiducials = args.fiducials;
  if (args.baseline_m > 0) spec.baseline_m = args.baseline_m;
  if (args.distance_m > 0) spec.working_distance_m = args.distance_m;
  if (args.noise >= 0) spec.sensor_noise = args.noise;
  if (args.voxel_m > 0) spec.voxel_m = args.voxel_m;
  args.beat.ApplyTo(&spec);
  if (!args.codec.empty()) spec.video_codec = args.codec;
  if (!args.ct_format.empty()) spec.ct_format = args.ct_format;
  if (!args.size.empty()) {
    std::smatch match;
    if (!std::regex_match(args.size, match, std::regex(R"((\d+)x(\d+))"))) {
      throw Error("--size must be WIDTHxHEIGHT (got '" + args.size + "')", "--size", "write e.g. 640x480");
    }
    spec.width = std::stoi(match[1]);
    spec.height = std::stoi(match[2]);
  }
  const phantom::PhantomSummary summary = phantom::GeneratePhantom(spec, args.out_dir, !args.quiet);
  std::fputs(summary.Describe().c_str(), stdout);
}

// The options of a phantom from a real CT; the synthetic scene's own options exclude --ct.
void AddRealCtOptions(CLI::App* command, PhantomArguments* args) {
  CLI::Option* ct = command->add_option(
      "--ct", args->ct,
      "Instead of the synthetic heart, warp this real CT (a NIfTI, NRRD or MetaImage file, or a DICOM series' "
      "folder) by a known motion into a 4D CT with its true displacement fields");
  command->add_option("--labels", args->labels,
                      "With --ct: its label map (same grid), copied to OUT/labels.nii.gz; the motion centres on it")
      ->needs(ct);
  command->add_option("--organ-label", args->organ_label,
                      "With --labels: the label the motion centres on (default 0: every non-zero label)")
      ->needs(ct);
  command->add_option("--motion", args->motion,
                      "With --ct: cardiac (contraction and twist) or respiratory (superior-inferior translation "
                      "and anterior-posterior expansion)")
      ->check(CLI::IsMember({"cardiac", "respiratory"}))
      ->capture_default_str()
      ->needs(ct);
  command->add_option("--amplitude-mm", args->amplitude_mm, "With --ct: the largest displacement, mm")
      ->check(CLI::PositiveNumber)
      ->capture_default_str()
      ->needs(ct);
  command->add_option("--period-s", args->period_s,
                      "With --ct: one cycle, seconds, for the trigger times (default: 1 cardiac, 4 respiratory)")
      ->check(CLI::PositiveNumber)
      ->needs(ct);
  for (const char* synthetic_only : {"--preset", "--heart-rate", "--tets", "--duration", "--size", "--fps",
                                     "--fiducials", "--baseline", "--distance", "--noise", "--codec", "--voxel"}) {
    ct->excludes(command->get_option(synthetic_only));
  }
}

}  // namespace

void AddPhantomCommand(CLI::App& app) {
  auto args = std::make_shared<PhantomArguments>();
  CLI::App* command = app.add_subcommand("phantom", "Generate a beating-heart phantom scene with exact ground truth");
  command->add_option("--out", args->out_dir, "Scene directory (created)")->required();
  command->add_option("--preset", args->preset, "default | tiny | stiff | extreme")
      ->check(CLI::IsMember({"default", "tiny", "stiff", "extreme"}))
      ->capture_default_str();
  command->add_option("--seed", args->seed, "Random seed: the same seed writes the same bytes")->capture_default_str();
  command->add_option("--heart-rate", args->heart_rate_bpm, "Heart rate, beats per minute (preset: 90)");
  phantom::AddBeatOptions(command, &args->beat);
  command->add_option("--phases", args->phases, "4D CT phases over one cycle (preset: 20)");
  command->add_option("--tets", args->tets, "Target tetrahedron count of the mesh (preset: 8000)");
  command->add_option("--duration", args->duration_s, "Video length, seconds (preset: 3.5)");
  command->add_option("--size", args->size, "Video size WIDTHxHEIGHT (preset: 640x480)");
  command->add_option("--fps", args->fps, "Video frame rate (preset: 30)");
  command->add_option("--fiducials", args->fiducials, "Fiducial beads and markers, at least 5 (preset: 6)");
  command->add_option("--baseline", args->baseline_m, "Stereo baseline, metres (preset: 0.005)");
  command->add_option("--distance", args->distance_m, "Working distance to the surface, metres (preset: 0.06)");
  command->add_option("--noise", args->noise, "Sensor noise, standard deviation in grey levels (preset: 2)");
  command->add_option("--codec", args->codec,
                      "Video codec, lossless either way: raw (uncompressed AVI, about 0.9 MB a 640x480 frame, "
                      "nothing to decode) or huffyuv (about 0.5 MB a frame, 3.5-4.5 ms to decode an eye) (default: raw)");
  command->add_option("--ct-format", args->ct_format,
                      "4D CT files: mhd (ct/phase_NN.mhd), dicom (a series per phase, ct/dicom/phase_NN/) or both "
                      "(default: both)")
      ->check(CLI::IsMember({"mhd", "dicom", "both"}));
  command->add_option("--voxel", args->voxel_m, "CT voxel size, metres (preset: 0.001)");
  command->add_option("--threads", args->threads, "Worker threads (default: all cores)")->check(CLI::PositiveNumber);
  command->add_flag("--quiet", args->quiet, "No progress lines");
  AddRealCtOptions(command, args.get());
  command->callback([args] { RunPhantomCommand(*args); });
}

}  // namespace dg::tools
