#include "io/scene.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "io/input_file.h"
#include "io/surface_mesh_reader.h"
#include "io/units.h"
#include "io/yaml_map.h"
#include "sim/error.h"
#include "sim/log.h"

namespace dg::io {
namespace {

namespace fs = std::filesystem;

// The absolute path of a file named at `key`, which must exist.
std::string ExistingFile(const YamlMap& map, const std::string& key, const fs::path& directory,
                         const std::string& relative) {
  const fs::path resolved = (directory / relative).lexically_normal();
  if (!fs::exists(resolved)) {
    throw Error("file not found: " + resolved.string(), map.Where(key),
                "correct the path (relative paths are relative to the scene file)");
  }
  return resolved.string();
}

std::string File(const YamlMap& map, const std::string& key, const fs::path& directory) {
  return ExistingFile(map, key, directory, map.String(key));
}

Scene::Preoperative ReadPreoperative(const YamlMap& map, const fs::path& directory) {
  Scene::Preoperative preoperative;
  preoperative.period_s = map.Number("period_s");
  preoperative.phases = map.Integer("phases", 0);
  if (!(preoperative.period_s > 0) || preoperative.phases < 2) {
    throw Error("period_s must be positive and phases at least 2", map.Where(), "give the 4D scan's period and phase count");
  }
  preoperative.motion = File(map, "motion", directory);
  if (map.Has("ct")) {
    const std::string pattern = map.String("ct");
    // The pattern reaches snprintf: allow exactly one integer conversion.
    if (!std::regex_match(pattern, std::regex(R"(([^%]|%%)*%0?[0-9]*d([^%]|%%)*)"))) {
      throw Error("'ct' must be a file pattern with one integer field, like ct/phase_%02d.mhd (got '" + pattern + "')",
                  map.Where("ct"), "write the phase number as %d or %02d");
    }
    for (int k = 0; k < preoperative.phases; ++k) {
      char name[1024];
      std::snprintf(name, sizeof name, pattern.c_str(), k);
      preoperative.ct_volumes.push_back(ExistingFile(map, "ct", directory, name));
    }
  }
  map.RejectUnknown();
  return preoperative;
}

// A surface mesh named at `key`: it exists, and its extension names a format read.
std::string SurfaceMeshFile(const YamlMap& map, const std::string& key, const fs::path& directory,
                            const std::string& relative) {
  const std::string path = ExistingFile(map, key, directory, relative);
  if (!IsSurfaceMeshFile(path)) {
    throw Error("'" + key + "' names " + path + ", not a surface mesh format read", map.Where(key),
                "give the mesh as " + SurfaceMeshExtensions() + " (the extension names the format)");
  }
  return path;
}

Scene::Overlays ReadOverlays(const YamlMap& map, const fs::path& directory) {
  Scene::Overlays overlays;
  // Applies to every length in the overlays' files; 3D Slicer and most
  // segmentation tools write millimetres.
  overlays.metres_per_unit = MetresPerUnit(map.String("units", "m"), map.Where("units"));
  if (map.Has("surface_mesh")) {
    overlays.surface_mesh = SurfaceMeshFile(map, "surface_mesh", directory, map.String("surface_mesh"));
  }
  if (map.Has("surface_texture")) overlays.surface_texture = File(map, "surface_texture", directory);
  if (map.Has("internal_meshes")) {
    const YAML::Node list = map.Node("internal_meshes");
    if (!list.IsSequence()) {
      throw Error("'internal_meshes' must be a list of files", map.Where("internal_meshes"), "write [a.obj, b.ply]");
    }
    for (const YAML::Node& item : list) {
      overlays.internal_meshes.push_back(SurfaceMeshFile(map, "internal_meshes", directory, item.as<std::string>()));
    }
  }
  if (map.Has("internal_points")) {
    const std::string value = map.String("internal_points");
    const size_t colon = value.find(':');
    const std::string file = value.substr(0, colon);
    overlays.internal_points = ExistingFile(map, "internal_points", directory, file) +
                               (colon == std::string::npos ? "" : value.substr(colon));
  }
  if (map.Has("order")) {
    const YAML::Node list = map.Node("order");
    if (!list.IsSequence()) throw Error("'order' must be a list", map.Where("order"), "write [texture, volume, meshes]");
    for (const YAML::Node& item : list) {
      const std::string name = item.as<std::string>();
      if (name != "texture" && name != "volume" && name != "meshes") {
        throw Error("unknown overlay '" + name + "'", map.Where("order"), "use texture, volume and meshes");
      }
      overlays.order.push_back(name);
    }
  }
  overlays.blend = map.String("blend", overlays.blend);
  if (overlays.blend != "inverse_realism" && overlays.blend != "alpha") {
    throw Error("unknown blend '" + overlays.blend + "'", map.Where("blend"), "use inverse_realism or alpha");
  }
  map.RejectUnknown();
  return overlays;
}

// `calibration:` one path or a list of paths (two or three: a stereo pair's
// files); `calibration_units:` the unit of their translations.
CalibrationSource ReadCalibrationSource(const YamlMap& top, const fs::path& directory) {
  CalibrationSource source;
  const YAML::Node node = top.Node("calibration");
  if (node.IsSequence()) {
    for (const YAML::Node& item : node) {
      if (!item.IsScalar()) {
        throw Error("'calibration' must be a file or a list of files", top.Where("calibration"),
                    "write calibration: calib.yaml or calibration: [intrinsics.yml, extrinsics.yml]");
      }
      source.files.push_back(ExistingFile(top, "calibration", directory, item.as<std::string>()));
    }
    if (source.files.empty() || source.files.size() > 3) {
      throw Error("'calibration' lists " + std::to_string(source.files.size()) + " files", top.Where("calibration"),
                  "give one file, two (intrinsics.yml and extrinsics.yml, or two camera_info) or three (two "
                  "camera_info and extrinsics.yml)");
    }
  } else {
    source.files.push_back(File(top, "calibration", directory));
  }
  if (top.Has("calibration_units")) {
    source.metres_per_unit =
        CalibrationMetresPerUnit(top.String("calibration_units"), top.Where("calibration_units"));
  }
  return source;
}

Scene::Video::Layout ReadLayout(const YamlMap& map) {
  const std::string name = map.String("layout", "two_files");
  if (name == "two_files") return Scene::Video::Layout::kTwoFiles;
  if (name == "side_by_side") return Scene::Video::Layout::kSideBySide;
  if (name == "image_sequences") return Scene::Video::Layout::kImageSequences;
  throw Error("unknown video layout '" + name + "'", map.Where("layout"),
              "use two_files, side_by_side (left eye in the left half) or image_sequences");
}

Scene::Video ReadVideo(const YamlMap& map, const fs::path& directory) {
  Scene::Video video;
  video.layout = ReadLayout(map);
  if (video.layout == Scene::Video::Layout::kImageSequences) {
    // Patterns name no single file: the capture stage says when nothing matches.
    video.left = (directory / map.String("left")).string();
    video.right = (directory / map.String("right")).string();
  } else {
    video.left = File(map, "left", directory);
    if (video.layout == Scene::Video::Layout::kTwoFiles) video.right = File(map, "right", directory);
  }
  video.fps = map.Number("fps");
  video.frames = map.Integer("frames", 0);
  video.rectified = map.Boolean("rectified", false);
  if (!(video.fps > 0)) throw Error("'fps' must be positive", map.Where("fps"), "give the video's frame rate");
  map.RejectUnknown();
  return video;
}

Scene::Registration ReadRegistration(const YamlMap& map, const fs::path& directory) {
  Scene::Registration registration;
  if (map.Has("file")) registration.file = File(map, "file", directory);
  registration.cycles = map.Number("cycles", registration.cycles);
  if (!(registration.cycles >= 1)) {
    throw Error("'cycles' must be at least 1", map.Where("cycles"), "register over one or more whole cardiac cycles");
  }
  if (map.Has("fiducials_uv")) registration.fiducials_uv = File(map, "fiducials_uv", directory);
  registration.live_phase = map.Boolean("live_phase", registration.live_phase);
  map.RejectUnknown();
  return registration;
}

Scene::Simulation ReadSimulation(const YamlMap& map) {
  Scene::Simulation simulation;
  simulation.mode = sim::ParseSimulationMode(map.String("mode", sim::ToString(simulation.mode)), map.Where("mode"));
  simulation.dt_s = map.Number("dt_s", simulation.dt_s);
  simulation.damping_per_s = map.Number("damping_per_s", simulation.damping_per_s);
  simulation.motion_smoothing = map.Number("motion_smoothing", simulation.motion_smoothing);
  simulation.concurrent = map.Boolean("concurrent", simulation.concurrent);
  simulation.inverse_interval_steps = map.Integer("inverse_interval_steps", simulation.inverse_interval_steps);
  simulation.precision =
      sim::ParsePrecision(map.String("precision", sim::ToString(simulation.precision)), map.Where("precision"));
  // A run never steps unchecked: that policy is for the solver's stability studies.
  simulation.time_step_policy =
      sim::ParseTimeStepPolicy(map.String("time_step_policy", sim::ToString(simulation.time_step_policy)),
                               map.Where("time_step_policy"), {sim::TimeStepPolicy::kRefuse, sim::TimeStepPolicy::kSubstep});
  simulation.sampled_nodes = map.Integer("sampled_nodes", simulation.sampled_nodes);
  simulation.max_tie_distance_m = map.Number("max_tie_distance_m", simulation.max_tie_distance_m);
  simulation.outlier_gate_min_m = map.Number("outlier_gate_min_m", simulation.outlier_gate_min_m);
  simulation.outlier_gate_scale = map.Number("outlier_gate_scale", simulation.outlier_gate_scale);
  simulation.outlier_neighbour_radius_m =
      map.Number("outlier_neighbour_radius_m", simulation.outlier_neighbour_radius_m);
  if (!(simulation.dt_s > 0)) throw Error("'dt_s' must be positive", map.Where("dt_s"), "the paper uses 2e-4 s");
  if (!(simulation.damping_per_s >= 0)) {
    throw Error("'damping_per_s' must not be negative", map.Where("damping_per_s"), "the paper uses 75 per second");
  }
  if (!(simulation.motion_smoothing >= 0)) {
    throw Error("'motion_smoothing' must not be negative", map.Where("motion_smoothing"), "0 interpolates the scan");
  }
  if (simulation.inverse_interval_steps < 1 || simulation.inverse_interval_steps > sim::kMaxInverseIntervalSteps) {
    throw Error("'inverse_interval_steps' must lie in [1, " + std::to_string(sim::kMaxInverseIntervalSteps) + "]",
                map.Where("inverse_interval_steps"),
                "1 recovers the forces at every step; the default " +
                    std::to_string(sim::kDefaultInverseIntervalSteps) + " blends them in between");
  }
  if (simulation.sampled_nodes < 0) {
    throw Error("'sampled_nodes' must not be negative", map.Where("sampled_nodes"), "0 logs no node positions");
  }
  if (!(simulation.max_tie_distance_m > 0)) {
    throw Error("'max_tie_distance_m' must be positive", map.Where("max_tie_distance_m"),
                "give about the surface mesh's edge length");
  }
  if (!(simulation.outlier_gate_min_m > 0)) {
    throw Error("'outlier_gate_min_m' must be positive", map.Where("outlier_gate_min_m"),
                "give about twice the tracked features' error (default 1e-3 m)");
  }
  if (!(simulation.outlier_gate_scale >= 1)) {
    throw Error("'outlier_gate_scale' must be at least 1", map.Where("outlier_gate_scale"),
                "give a multiple of the frame's median departure (default 3)");
  }
  if (!(simulation.outlier_neighbour_radius_m > 0)) {
    throw Error("'outlier_neighbour_radius_m' must be positive", map.Where("outlier_neighbour_radius_m"),
                "give a few surface mesh edges (default 5e-3 m)");
  }
  map.RejectUnknown();
  return simulation;
}

}  // namespace

Scene ReadScene(const std::string& path) {
  const std::string text = ReadTextFile(path, "scene file", "check the path (dynaguide phantom writes one)");
  const YAML::Node root = ParseYaml(text, path);
  const fs::path directory = fs::absolute(path).parent_path();
  const YamlMap top(root, path, "");
  Scene scene;
  scene.path = fs::absolute(path).string();
  scene.text = text;
  scene.name = top.String("name", fs::path(path).parent_path().filename().string());

  const YamlMap mesh = top.Map("mesh");
  scene.mesh.file = File(mesh, "file", directory);
  scene.mesh.metres_per_unit = MetresPerUnit(mesh.String("units", "m"), mesh.Where("units"));
  scene.mesh.fixed_set = mesh.String("fixed_set", scene.mesh.fixed_set);
  scene.mesh.surface_set = mesh.String("surface_set", scene.mesh.surface_set);
  mesh.RejectUnknown();

  if (top.Has("material")) {
    scene.material = ReadMaterial(top.Map("material"));
  } else if (top.Has("simulation")) {
    Logger("io").warn("{}: no material: block; the simulation uses E = {} Pa, nu = {}, density {} kg/m^3", path,
                      scene.material.youngs_modulus_pa, scene.material.poissons_ratio, scene.material.density_kg_m3);
  }
  if (top.Has("preoperative")) scene.preoperative = ReadPreoperative(top.Map("preoperative"), directory);
  if (top.Has("overlays")) scene.overlays = ReadOverlays(top.Map("overlays"), directory);
  scene.calibration = ReadCalibrationSource(top, directory);
  if (top.Has("calibration_images")) scene.calibration_images = (directory / top.String("calibration_images")).string();

  scene.video = ReadVideo(top.Map("video"), directory);

  if (top.Has("registration")) scene.registration = ReadRegistration(top.Map("registration"), directory);
  if (top.Has("simulation")) {
    scene.simulation = ReadSimulation(top.Map("simulation"));
    if (!scene.preoperative && scene.simulation->mode != sim::SimulationMode::kSurface) {
      throw Error("simulation mode '" + sim::ToString(scene.simulation->mode) +
                      "' needs the scan's motion (preoperative:)",
                  top.Where("simulation"), "add a preoperative: block, or use mode: surface");
    }
  }
  if (top.Has("truth")) scene.truth = File(top, "truth", directory);
  top.RejectUnknown();
  return scene;
}

}  // namespace dg::io
