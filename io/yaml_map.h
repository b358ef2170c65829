#pragma once

#include <set>
#include <string>

#include <Eigen/Core>
#include <yaml-cpp/yaml.h>

#include "sim/material.h"

namespace dg::io {

// Strict reading of one YAML mapping: every key read is remembered, and
// RejectUnknown() turns any other key into an error naming file, line and key
// path, so that a misspelt option is never silently ignored. Values of the
// wrong type are errors naming the key and the expected type.
class YamlMap {
 public:
  // @throws dg::Error if node is not a mapping.
  YamlMap(const YAML::Node& node, std::string file, std::string key_path);

  bool Has(const std::string& key) const;
  double Number(const std::string& key) const;
  double Number(const std::string& key, double default_value) const;
  int Integer(const std::string& key, int default_value) const;
  bool Boolean(const std::string& key, bool default_value) const;
  std::string String(const std::string& key) const;
  std::string String(const std::string& key, const std::string& default_value) const;
  Eigen::Vector3d Vector3(const std::string& key) const;
  Eigen::Vector3d Vector3(const std::string& key, const Eigen::Vector3d& default_value) const;
  YamlMap Map(const std::string& key) const;
  YAML::Node Node(const std::string& key) const;  // marks the key as known

  // "file:line (key.path.key)" of a key, or of the map itself for "".
  std::string Where(const std::string& key = "") const;
  const std::string& file() const { return file_; }

  // @throws dg::Error naming the first unknown key and the keys allowed here.
  void RejectUnknown() const;

 private:
  YAML::Node Get(const std::string& key) const;
  template <typename T>
  T Convert(const std::string& key, const char* type_name) const;

  YAML::Node node_;
  std::string file_;
  std::string key_path_;
  mutable std::set<std::string> known_;
};

// Parses YAML text. @throws dg::Error naming path:line of a syntax error.
YAML::Node ParseYaml(const std::string& text, const std::string& path);

// The `material:` block shared by problems and scenes: the paper's values for
// keys not given. @throws dg::Error for an unknown key or an invalid material.
sim::Material ReadMaterial(const YamlMap& map);

}  // namespace dg::io
