// `dynaguide register`: spatiotemporal registration of the 4D scan to the video.
#include <cstdio>

#include <CLI/CLI.hpp>

#include "io/registration_file.h"
#include "tools/commands.h"
#include "tools/register/register_run.h"

namespace dg::tools {

void AddRegisterCommand(CLI::App& app) {
  auto options = std::make_shared<RegisterRunOptions>();
  auto json_path = std::make_shared<std::string>();
  auto out_path = std::make_shared<std::string>();
  CLI::App* command =
      app.add_subcommand("register", "Register the 4D scan to the stereo video in space and time (paper section 2.2)");
  command->add_option("scene", options->scene, "Scene file (scene.yaml) with preoperative data, video and calibration")
      ->required();
  command->add_option("--cycles", options->cycles,
                      "Cardiac cycles to register over (default: the scene's registration.cycles, else 3)");
  command->add_option("--fiducials-uv", options->fiducials_uv,
                      "Fiducials' pixels in the first left frame, one u,v line each in the scan's order "
                      "(default: the scene's registration.fiducials_uv, else its truth's)");
  command->add_flag("--ct-beads", options->ct_beads, "Find the fiducials as beads in the CT volumes instead of reading the scan file");
  command->add_option("--json", *json_path, "Save the result as JSON");
  command->add_option("--out", *out_path, "Save the registration as YAML for a scene to reuse");
  command->callback([options, json_path, out_path] {
    options->progress = true;
    const RegisterRunSummary summary = RunRegister(*options);
    std::fputs(RegisterReport(summary).c_str(), stdout);
    if (!json_path->empty()) {
      WriteRegisterJson(*json_path, summary);
      std::printf("saved %s\n", json_path->c_str());
    }
    if (!out_path->empty()) {
      io::WriteRegistrationYaml(*out_path, summary.result.registration);
      std::printf("saved %s\n", out_path->c_str());
    }
  });
}

}  // namespace dg::tools
