#include "io/mesh_fields.h"

#include <algorithm>
#include <cctype>
#include <set>

#include "sim/error.h"

namespace dg::io {
namespace {

bool IsSafeName(const std::string& name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](unsigned char c) {
    return std::isalnum(c) || c == '_' || c == '-' || c == '.';
  });
}

// kind is "point" or "cell", column what each column stands for ("node", "element").
void CheckGroup(const std::vector<std::pair<std::string, Eigen::MatrixXd>>& data, int columns,
                const std::string& kind, const std::string& column, const std::string& where) {
  std::set<std::string> seen = {kDisplacementName};
  for (const auto& [name, values] : data) {
    if (!IsSafeName(name)) {
      throw Error(kind + " field name '" + name + "' is empty or has unsafe characters", where,
                  "use letters, digits, '_', '-' or '.', e.g. stress_Pa");
    }
    if (!seen.insert(name).second) {
      throw Error(kind + " field name '" + name + "' is used twice or is reserved", where,
                  "give each field its own name (displacement_m is written by the writer)");
    }
    if (values.rows() < 1 || values.cols() != columns) {
      throw Error(kind + " field '" + name + "' is " + std::to_string(values.rows()) + " x " +
                      std::to_string(values.cols()) + ", expected components x " +
                      std::to_string(columns),
                  where, "give one column per " + column + " and one row per component");
    }
  }
}

}  // namespace

void CheckMeshFields(const MeshFields& fields, int num_nodes, int num_cells,
                     const std::string& where) {
  CheckGroup(fields.point_data, num_nodes, "point", "node", where);
  CheckGroup(fields.cell_data, num_cells, "cell", "element", where);
}

}  // namespace dg::io
