#include "tools/preop/like_scene.h"

#include <filesystem>
#include <fstream>

#include <yaml-cpp/yaml.h>

#include "io/scene.h"
#include "sim/error.h"

namespace dg::tools::preop {
namespace fs = std::filesystem;

void WriteSceneLike(const std::string& like_scene, const std::string& out_dir, const PreopSceneParts& parts) {
  const io::Scene like = io::ReadScene(like_scene);
  if (!like.preoperative && !(parts.period_s > 0)) {
    throw Error("the scene has no preoperative block to take the CT's period from", like_scene,
                "give --period-s");
  }
  YAML::Node root = YAML::LoadFile(like_scene);
  const fs::path directory = fs::absolute(fs::path(like_scene)).parent_path();
  const auto absolute = [&](const YAML::Node& node) { return (directory / node.as<std::string>()).lexically_normal().string(); };

  root["name"] = root["name"].as<std::string>("scene") + "-preop";
  YAML::Node mesh;
  mesh["file"] = "mesh.msh";
  mesh["units"] = "m";
  mesh["fixed_set"] = "base";
  mesh["surface_set"] = "surface";
  root["mesh"] = mesh;

  YAML::Node preoperative;
  preoperative["period_s"] = parts.period_s > 0 ? parts.period_s : like.preoperative->period_s;
  preoperative["phases"] = parts.phases;
  preoperative["motion"] = "scan.h5";
  preoperative["ct"] = "ct/phase_%02d.mhd";
  root["preoperative"] = preoperative;

  YAML::Node overlays;
  overlays["surface_mesh"] = "assets/surface.obj";
  if (parts.texture) {
    for (const auto& entry : fs::directory_iterator(fs::path(out_dir) / "assets")) {
      if (entry.path().stem() == "annotation") overlays["surface_texture"] = "assets/" + entry.path().filename().string();
    }
  }
  for (int s = 0; s < parts.internal_meshes; ++s) {
    overlays["internal_meshes"].push_back("assets/internal_" + std::to_string(s) + ".obj");
  }
  if (like.overlays && !like.overlays->internal_points.empty()) {
    overlays["internal_points"] = like.overlays->internal_points;  // already absolute, with its dataset
  }
  if (const YAML::Node given = root["overlays"]) {
    for (const char* kept : {"order", "blend"}) {
      if (given[kept]) overlays[kept] = given[kept];
    }
  }
  root["overlays"] = overlays;

  for (const char* key : {"calibration_images", "truth"}) {
    if (root[key]) root[key] = absolute(root[key]);
  }
  if (root["calibration"] && root["calibration"].IsSequence()) {  // a stereo pair's files
    YAML::Node files(YAML::NodeType::Sequence);
    for (const YAML::Node& file : root["calibration"]) files.push_back(absolute(file));
    root["calibration"] = files;
  } else if (root["calibration"]) {
    root["calibration"] = absolute(root["calibration"]);
  }
  for (const char* key : {"left", "right"}) {
    if (root["video"][key]) root["video"][key] = absolute(root["video"][key]);
  }
  for (const char* key : {"file", "fiducials_uv"}) {
    if (root["registration"] && root["registration"][key]) root["registration"][key] = absolute(root["registration"][key]);
  }

  const std::string path = out_dir + "/scene.yaml";
  std::ofstream file(path);
  file << "# A dynaguide scene: preoperative part by `dynaguide preop` from a 4D CT, the rest from\n# "
       << fs::absolute(like_scene).string() << ". Lengths in metres, times in seconds.\n";
  if (parts.fiducials == 0) {
    file << "# The scan has NO fiducials: `dynaguide run` cannot register it to the video. Mark them at the CT's\n"
            "# first phase (3D Slicer markups) and run `dynaguide preop ... --fiducials FILE --resume`.\n";
  }
  file << YAML::Dump(root) << "\n";
  if (!file) throw Error("cannot write the scene", path, "check the folder's permissions and free space");
}

}  // namespace dg::tools::preop
