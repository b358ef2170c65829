// `dynaguide export`: a scene in the files other tools load. `export slicer`
// writes 3D Slicer's (tools/export/slicer_export.h).
#include <cstdio>
#include <memory>

#include <CLI/CLI.hpp>

#include "tools/commands.h"
#include "tools/export/slicer_export.h"

namespace dg::tools {

void AddExportCommand(CLI::App& app) {
  CLI::App* command = app.add_subcommand("export", "Export a scene's meshes, CT and registration for other tools");
  command->require_subcommand(1);
  auto options = std::make_shared<SlicerExportOptions>();
  CLI::App* slicer = command->add_subcommand(
      "slicer", "For 3D Slicer: meshes as VTK, the registration as an ITK transform, the CT, in millimetres");
  slicer->add_option("scene", options->scene, "Scene file (scene.yaml) with overlay meshes")->required();
  slicer->add_option("--out", options->out_dir, "Output folder (created)")->required();
  slicer->add_option("--registration", options->registration,
                     "Registration YAML (`dynaguide register --out`, or the one `dynaguide run` writes); "
                     "default: the scene's registration: {file: ...}");
  slicer->callback([options] {
    const SlicerExport exported = ExportForSlicer(*options);
    std::printf("exported for 3D Slicer into %s (millimetres, scan frame S = LPS):\n", exported.out_dir.c_str());
    for (const ExportedFile& file : exported.files) std::printf("  %-28s %s\n", file.name.c_str(), file.what.c_str());
    if (exported.ct_file.empty()) std::printf("  no CT: the scene has no preoperative: {ct: ...}\n");
    std::printf("load: README.txt in that folder says how\n");
  });
}

}  // namespace dg::tools
