// `dynaguide bench`: throughput figures that the README quotes (`bench sim`
// in sim_bench_command.cc).
#include <algorithm>
#include <cstdio>

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include "tools/bench/bench_json.h"
#include "tools/bench/overlay_bench.h"
#include "tools/bench/pipeline_bench.h"
#include "tools/bench/register_bench.h"
#include "tools/bench/run_bench.h"
#include "tools/bench/vision_bench.h"
#include "tools/commands.h"
#include "tools/overlay_quality_options.h"
#include "tools/preop/preop_bench.h"

namespace dg::tools {
namespace {

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
    PrintAndSave(VisionBenchTable(records), *json_path, records, WriteVisionBenchJson);
  });
}

void AddOverlayBench(CLI::App& bench) {
  auto options = std::make_shared<OverlayBenchOptions>();
  auto json_path = std::make_shared<std::string>();
  CLI::App* command = bench.add_subcommand("overlay", "Overlays (meshes, texture, CT volume) and compositing per frame on the phantom");
  command->add_option("--threads", options->threads, "Thread counts")->delimiter(',')->capture_default_str();
  command->add_option("--frames", options->frames, "Frames timed per overlay and thread count")->capture_default_str();
  command->add_option("--seconds", options->duration_s, "Length of the generated phantom video")->capture_default_str();
  AddOverlayQualityOptions(command, &options->quality);
  command->add_option("--json", *json_path, "Save the records to this JSON file");
  command->callback([options, json_path] {
    PrintMachine();
    const std::vector<OverlayBenchRecord> records = RunOverlayBench(*options, true);
    PrintAndSave(OverlayBenchTable(records), *json_path, records, WriteOverlayBenchJson);
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
    PrintAndSave(RegisterBenchTable(records), *json_path, records, WriteRegisterBenchJson);
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
    PrintAndSave(preop::PreopBenchTable(record), *json_path, record, preop::WritePreopBenchJson);
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
    PrintAndSave(PipelineBenchTable(records), *json_path, records, WritePipelineBenchJson);
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
    PrintAndSave(RunBenchTable(records), *json_path, records, WriteRunBenchJson);
  });
}

}  // namespace

void AddBenchCommand(CLI::App& app) {
  CLI::App* bench = AddBenchGroup(app);

  AddSimBench(*bench);
  AddVisionBench(*bench);
  AddRegisterBench(*bench);
  AddPreopBench(*bench);
  AddOverlayBench(*bench);
  AddPipelineBench(*bench);
  AddRunBench(*bench);
}

}  // namespace dg::tools
