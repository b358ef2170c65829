// `dynaguide bench sim|vision`: throughput figures that the README quotes.
#include <algorithm>
#include <cstdio>

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include "pipeline/machine_info.h"
#include "tools/bench/overlay_bench.h"
#include "tools/bench/pipeline_bench.h"
#include "tools/bench/register_bench.h"
#include "tools/bench/run_bench.h"
#include "tools/bench/sim_bench.h"
#include "tools/bench/vision_bench.h"
#include "tools/commands.h"
#include "tools/preop/preop_bench.h"

namespace dg::tools {
namespace {

void PrintMachine() {
  const pipeline::MachineInfo machine = pipeline::ReadMachineInfo();
  std::printf("machine: %s, %d logical cores, %s, %s\n", machine.cpu_model.c_str(), machine.logical_cores,
              machine.simd.c_str(), machine.compiler.c_str());
}

void AddVisionBench(CLI::App& bench) {
  auto options = std::make_shared<VisionBenchOptions>();
  auto json_path = std::make_shared<std::string>();
  CLI::App* vision = bench.add_subcommand("vision", "Stereo front end per frame (capture to triangulation) on the phantom");
  vision->add_option("--threads", options->threads, "Thread counts")->delimiter(',')->capture_default_str();
  vision->add_option("--frames", options->frames, "Frames timed per run (0: all)")->capture_default_str();
  vision->add_option("--repeats", options->repeats, "Runs per codec and thread count; the run of median fps is reported")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  vision->add_option("--seconds", options->duration_s, "Length of the generated phantom video")->capture_default_str();
  vision->add_option("--codecs", options->codecs, "The phantom video's codecs measured: raw (uncompressed), huffyuv")
      ->delimiter(',')
      ->capture_default_str();
  vision->add_option("--json", *json_path, "Save the records to this JSON file");
  vision->callback([options, json_path] {
    PrintMachine();
    const std::vector<VisionBenchRecord> records = RunVisionBench(*options, true);
    std::fputs(VisionBenchTable(records).c_str(), stdout);
    if (!json_path->empty()) {
      WriteVisionBenchJson(*json_path, records);
      std::printf("saved %s\n", json_path->c_str());
    }
  });
}

void AddOverlayBench(CLI::App& bench) {
  auto options = std::make_shared<OverlayBenchOptions>();
  auto json_path = std::make_shared<std::string>();
  CLI::App* command = bench.add_subcommand("overlay", "Overlays (meshes, texture, CT volume) and compositing per frame on the phantom");
  command->add_option("--threads", options->threads, "Thread counts")->delimiter(',')->capture_default_str();
  command->add_option("--frames", options->frames, "Frames timed per overlay and thread count")->capture_default_str();
  command->add_option("--seconds", options->duration_s, "Length of the generated phantom video")->capture_default_str();
  command->add_option("--supersample", options->supersample, "Surface overlays' samples per pixel per axis")
      ->capture_default_str();
  command->add_option("--slice-spacing", options->slice_spacing_m, "Volume slice spacing, metres")->capture_default_str();
  command->add_option("--json", *json_path, "Save the records to this JSON file");
  command->callback([options, json_path] {
    PrintMachine();
    const std::vector<OverlayBenchRecord> records = RunOverlayBench(*options, true);
    std::fputs(OverlayBenchTable(records).c_str(), stdout);
    if (!json_path->empty()) {
      WriteOverlayBenchJson(*json_path, records);
      std::printf("saved %s\n", json_path->c_str());
    }
  });
}

void AddRegisterBench(CLI::App& bench) {
  auto options = std::make_shared<RegisterBenchOptions>();
  auto json_path = std::make_shared<std::string>();
  CLI::App* command = bench.add_subcommand("register", "Spatiotemporal registration (search and refinement) on the phantom");
  command->add_option("--threads", options->threads, "Thread counts")->delimiter(',')->capture_default_str();
  command->add_option("--repeats", options->repeats, "Timed registrations; the median is reported")->capture_default_str();
  command->add_option("--fiducials", options->fiducials, "Fiducials in the phantom")->capture_default_str();
  command->add_option("--cycles", options->cycles, "Cardiac cycles registered over")->capture_default_str();
  command->add_option("--json", *json_path, "Save the records to this JSON file");
  command->callback([options, json_path] {
    PrintMachine();
    const std::vector<RegisterBenchRecord> records = RunRegisterBench(*options, true);
    std::fputs(RegisterBenchTable(records).c_str(), stdout);
    if (!json_path->empty()) {
      WriteRegisterBenchJson(*json_path, records);
      std::printf("saved %s\n", json_path->c_str());
    }
  });
}

void AddPreopBench(CLI::App& bench) {
  auto out_dir = std::make_shared<std::string>("out/bench-preop");
  auto threads = std::make_shared<int>(0);
  auto json_path = std::make_shared<std::string>();
  CLI::App* command = bench.add_subcommand(
      "preop", "dynaguide preop on the default phantom's DICOM 4D CT, against the phantom's exact motion");
  command->add_option("--out", *out_dir, "Where the scene goes (kept, with scene.yaml)")->capture_default_str();
  command->add_option("--threads", *threads, "Worker threads (default: all cores)");
  command->add_option("--json", *json_path, "Save the record to this JSON file");
  command->callback([out_dir, threads, json_path] {
    PrintMachine();
    const int count = *threads > 0 ? *threads : tbb::info::default_concurrency();
    tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, count);
    const preop::PreopBenchRecord record = preop::RunPreopBench(*out_dir, count, true);
    std::fputs(preop::PreopBenchTable(record).c_str(), stdout);
    if (!json_path->empty()) {
      preop::WritePreopBenchJson(*json_path, record);
      std::printf("saved %s\n", json_path->c_str());
    }
  });
}

void AddPipelineBench(CLI::App& bench) {
  auto options = std::make_shared<PipelineBenchOptions>();
  auto json_path = std::make_shared<std::string>();
  CLI::App* command =
      bench.add_subcommand("pipeline", "The front-end graph offline: throughput, latency, overhead against a plain loop");
  command->add_option("scene", options->scene, "scene.yaml (default: the built-in default phantom)");
  command->add_option("--threads", options->threads, "Thread counts")->delimiter(',')->capture_default_str();
  command->add_option("--repeats", options->repeats, "Runs per configuration; the median is reported")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command->add_option("--frames", options->frames, "Frames per run (0: the whole recording)")->capture_default_str();
  command->add_option("--json", *json_path, "Save the records to this JSON file");
  command->callback([options, json_path] {
    PrintMachine();
    const std::vector<PipelineBenchRecord> records = RunPipelineBench(*options, true);
    std::fputs(PipelineBenchTable(records).c_str(), stdout);
    if (!json_path->empty()) {
      WritePipelineBenchJson(*json_path, records);
      std::printf("saved %s\n", json_path->c_str());
    }
  });
}

void AddRunBench(CLI::App& bench) {
  auto options = std::make_shared<RunBenchOptions>();
  auto policies = std::make_shared<std::vector<std::string>>(std::vector<std::string>{"offline", "realtime"});
  auto json_path = std::make_shared<std::string>();
  CLI::App* command = bench.add_subcommand(
      "run", "`dynaguide run` of the whole scene, repeated: real-time factor, drops and latency per run");
  command->add_option("scene", options->scene, "scene.yaml (default: the built-in default phantom)");
  command->add_option("--policy", *policies, "Policies to run")
      ->delimiter(',')
      ->check(CLI::IsMember({"offline", "realtime"}))
      ->capture_default_str();
  command->add_option("--threads", options->threads, "Threads for each run")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command->add_option("--repeats", options->repeats, "Runs per policy, each reported")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command->add_option("--json", *json_path, "Save the records to this JSON file");
  command->callback([options, policies, json_path] {
    PrintMachine();
    options->policies.clear();
    for (const std::string& policy : *policies) options->policies.push_back(pipeline::ParsePolicy(policy));
    const std::vector<RunBenchRecord> records = RunRunBench(*options, true);
    std::fputs(RunBenchTable(records).c_str(), stdout);
    if (!json_path->empty()) {
      WriteRunBenchJson(*json_path, records);
      std::printf("saved %s\n", json_path->c_str());
    }
  });
}

}  // namespace

void AddBenchCommand(CLI::App& app) {
  CLI::App* bench = app.add_subcommand("bench", "Measure throughput; figures are printed and saved as JSON");
  bench->require_subcommand(1);

  auto options = std::make_shared<SimBenchOptions>();
  auto json_path = std::make_shared<std::string>();
  CLI::App* sim = bench->add_subcommand("sim", "TLED tetrahedron-steps per second on Gmsh boxes (forward) or the phantom (inverse + forward)");
  sim->add_option("--mode", options->modes,
                  "forward (solver on boxes) and/or combined, volume, surface (inverse + forward on the phantom)")
      ->delimiter(',')
      ->check(CLI::IsMember({"forward", "combined", "volume", "surface"}))
      ->capture_default_str();
  CLI::Option* tets =
      sim->add_option("--tets", options->tets, "Target mesh sizes (phantom modes: 8000, the default phantom's)")
          ->delimiter(',')
          ->capture_default_str();
  sim->add_option("--threads", options->threads, "Thread counts")->delimiter(',')->capture_default_str();
  sim->add_option("--mesh", options->mesh_path,
                  "forward: a Gmsh .msh file (metres) instead of the boxes, in its own node order; its lowest z "
                  "face fixed, its highest pressed down")
      ->check(CLI::ExistingFile);
  sim->add_flag("--shuffled", options->shuffled_too, "forward: also each mesh with its nodes in a random order");
  auto precisions = std::make_shared<std::vector<std::string>>(std::vector<std::string>{"float", "double"});
  sim->add_option("--precision", *precisions, "float and/or double")->delimiter(',')->capture_default_str();
  sim->add_option("--inverse-interval", options->inverse_intervals,
                  "combined, volume: forward steps per level of recovered forces, each measured with its error")
      ->delimiter(',')
      ->check(CLI::Range(1, sim::kMaxInverseIntervalSteps))
      ->capture_default_str();
  sim->add_option("--repeats", options->repeats, "Timed repeats; the median is reported")->capture_default_str();
  sim->add_option("--seconds", options->simulated_per_repeat_s, "Simulated seconds per repeat")->capture_default_str();
  sim->add_option("--json", *json_path, "Save the records to this JSON file");
  sim->callback([options, precisions, json_path, tets] {
    options->precisions.clear();
    for (const std::string& name : *precisions) options->precisions.push_back(sim::ParsePrecision(name, "--precision"));
    const bool forward = std::find(options->modes.begin(), options->modes.end(), "forward") != options->modes.end();
    if (tets->count() == 0 && !forward) options->tets = {8000};
    PrintMachine();
    const std::vector<SimBenchRecord> records = RunSimBench(*options, true);
    std::fputs(SimBenchTable(records).c_str(), stdout);
    if (!json_path->empty()) {
      WriteSimBenchJson(*json_path, records);
      std::printf("saved %s\n", json_path->c_str());
    }
  });
  AddVisionBench(*bench);
  AddRegisterBench(*bench);
  AddPreopBench(*bench);
  AddOverlayBench(*bench);
  AddPipelineBench(*bench);
  AddRunBench(*bench);
}

}  // namespace dg::tools
