#include "io/yaml_map.h"

#include <set>

#include "sim/error.h"

namespace dg::io {

YamlMap::YamlMap(const YAML::Node& node, std::string file, std::string key_path)
    : node_(node), file_(std::move(file)), key_path_(std::move(key_path)) {
  if (!node_.IsMap()) {
    throw Error("expected a mapping of keys to values", Where(),
                "write it as 'key: value' lines (see the example in the documentation)");
  }
  // YAML readers disagree on a repeated key (yaml-cpp keeps the first, others
  // the last): either way one of the two values the user wrote is dropped.
  std::set<std::string> seen;
  for (const auto& entry : node_) {
    const std::string key = entry.first.Scalar();
    if (seen.insert(key).second) continue;
    throw Error("key '" + key + "' appears twice",
                file_ + ":" + std::to_string(entry.first.Mark().line + 1) + " (" +
                    (key_path_.empty() ? key : key_path_ + "." + key) + ")",
                "keep one of the two '" + key + ":' lines");
  }
}

std::string YamlMap::Where(const std::string& key) const {
  const YAML::Node located = key.empty() || !node_[key] ? node_ : node_[key];
  const int line = located.Mark().line + 1;
  std::string path = key_path_;
  if (!key.empty()) path += path.empty() ? key : "." + key;
  return file_ + ":" + std::to_string(line) + " (" + (path.empty() ? "top level" : path) + ")";
}

bool YamlMap::Has(const std::string& key) const {
  known_.insert(key);
  return static_cast<bool>(node_[key]);
}

YAML::Node YamlMap::Get(const std::string& key) const {
  known_.insert(key);
  const YAML::Node value = node_[key];
  if (!value) throw Error("missing required key '" + key + "'", Where(), "add '" + key + ": ...'");
  return value;
}

template <typename T>
T YamlMap::Convert(const std::string& key, const char* type_name) const {
  const YAML::Node value = Get(key);
  try {
    if (!value.IsScalar()) throw YAML::Exception(value.Mark(), "not a scalar");
    return value.as<T>();
  } catch (const YAML::Exception&) {
    throw Error("'" + key + "' must be " + type_name, Where(key), "give " + std::string(type_name));
  }
}

double YamlMap::Number(const std::string& key) const { return Convert<double>(key, "a number"); }
double YamlMap::Number(const std::string& key, double default_value) const {
  return Has(key) ? Number(key) : default_value;
}
int YamlMap::Integer(const std::string& key, int default_value) const {
  return Has(key) ? Convert<int>(key, "an integer") : default_value;
}
bool YamlMap::Boolean(const std::string& key, bool default_value) const {
  return Has(key) ? Convert<bool>(key, "true or false") : default_value;
}
std::string YamlMap::String(const std::string& key) const { return Convert<std::string>(key, "a string"); }
std::string YamlMap::String(const std::string& key, const std::string& default_value) const {
  return Has(key) ? String(key) : default_value;
}

Eigen::Vector3d YamlMap::Vector3(const std::string& key) const {
  const YAML::Node value = Get(key);
  Eigen::Vector3d v;
  try {
    if (!value.IsSequence() || value.size() != 3) throw YAML::Exception(value.Mark(), "not a triple");
    for (int i = 0; i < 3; ++i) v[i] = value[i].as<double>();
  } catch (const YAML::Exception&) {
    throw Error("'" + key + "' must be a list of three numbers", Where(key), "write it as [x, y, z]");
  }
  return v;
}
Eigen::Vector3d YamlMap::Vector3(const std::string& key, const Eigen::Vector3d& default_value) const {
  return Has(key) ? Vector3(key) : default_value;
}

YamlMap YamlMap::Map(const std::string& key) const {
  return YamlMap(Get(key), file_, key_path_.empty() ? key : key_path_ + "." + key);
}

YAML::Node YamlMap::Node(const std::string& key) const { return Get(key); }

void YamlMap::RejectUnknown() const {
  for (const auto& entry : node_) {
    const std::string key = entry.first.as<std::string>();
    if (known_.count(key)) continue;
    std::string allowed;
    for (const std::string& k : known_) allowed += (allowed.empty() ? "" : ", ") + k;
    throw Error("unknown key '" + key + "'", file_ + ":" + std::to_string(entry.first.Mark().line + 1) +
                    " (" + (key_path_.empty() ? key : key_path_ + "." + key) + ")",
                "remove it or correct its spelling; allowed here: " + allowed);
  }
}

YAML::Node ParseYaml(const std::string& text, const std::string& path) {
  try {
    return YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw Error("not valid YAML: " + e.msg, path + ":" + std::to_string(e.mark.line + 1),
                "correct the syntax (indentation, colons, brackets)");
  }
}

sim::Material ReadMaterial(const YamlMap& map) {
  sim::Material material;
  material.youngs_modulus_pa = map.Number("youngs_modulus_pa", material.youngs_modulus_pa);
  material.poissons_ratio = map.Number("poissons_ratio", material.poissons_ratio);
  material.density_kg_m3 = map.Number("density_kg_m3", material.density_kg_m3);
  map.RejectUnknown();
  if (const std::string wrong = material.Validate(); !wrong.empty()) {
    throw Error(wrong, map.Where(), "correct the material");
  }
  return material;
}

}  // namespace dg::io
