#include "io/gmsh_reader.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "io/input_file.h"
#include "sim/error.h"
#include "sim/log.h"

namespace dg::io {
namespace {

const std::string kRegenerate =
    "regenerate the file with Gmsh (e.g. gmsh -3 -format msh41 model.geo)";
const std::string kRemesh =
    "re-mesh with first-order tetrahedra only: gmsh -3 -order 1 model.geo (no Recombine)";

// Reads a .msh file one line at a time, split into whitespace-separated tokens,
// so that every error can name the line it is on.
class LineReader {
 public:
  explicit LineReader(const std::string& path) : path_(path) {
    RequireRegularFile(path, "mesh file", "check the path: give a Gmsh .msh file");
    in_.open(path);
    if (!in_) {
      throw Error("cannot open mesh file", path, "check the path and that the file is readable");
    }
    RequireTextStart();
  }

  // Moves to the next non-blank line; false at the end of the file.
  bool Next() {
    while (std::getline(in_, line_)) {
      ++line_number_;
      Tokenize();
      if (!tokens_.empty()) return true;
    }
    return false;
  }

  // Next() inside a section, where the end of the file means it was truncated.
  void NextIn(std::string_view section) {
    if (!Next()) {
      Fail("file ends inside the " + std::string(section) + " section (after this line)",
           "the file is truncated; " + kRegenerate);
    }
  }

  // NextIn() for one of the entries a section header has counted.
  void NextEntry(std::string_view section) {
    NextIn(section);
    if (tokens_[0].front() == '$') {
      Fail("the " + std::string(section) + " section ends before all the entries its header counts",
           "correct the count in the section header, or " + kRegenerate);
    }
  }

  // Reads the line that must close `section`, e.g. $EndNodes for $Nodes.
  void ExpectEnd(std::string_view section) {
    const std::string end = "$End" + std::string(section.substr(1));
    NextIn(section);
    if (tokens_[0] != end) {
      Fail("expected " + end + " but found '" + line_ + "'",
           "the section holds more entries than its header counts; correct the count, or " +
               kRegenerate);
    }
  }

  size_t size() const { return tokens_.size(); }
  std::string_view token(size_t i) const { return tokens_[i]; }
  const std::string& line() const { return line_; }

  void RequireTokens(size_t count, std::string_view what) const {
    if (tokens_.size() < count) {
      Fail("line too short for " + std::string(what) + ": expected at least " +
               std::to_string(count) + " values, found " + std::to_string(tokens_.size()),
           "correct the line, or " + kRegenerate);
    }
  }

  long long Integer(size_t i, std::string_view what) const {
    RequireTokens(i + 1, what);
    const std::string_view s = tokens_[i];
    long long value = 0;
    const auto [end, error] = std::from_chars(s.data(), s.data() + s.size(), value);
    if (error != std::errc() || end != s.data() + s.size()) {
      Fail("'" + std::string(s) + "' is not an integer (" + std::string(what) + ")",
           "correct the number on this line, or " + kRegenerate);
    }
    return value;
  }

  double Real(size_t i, std::string_view what) const {
    RequireTokens(i + 1, what);
    std::string_view s = tokens_[i];
    if (s.size() > 1 && s.front() == '+') s.remove_prefix(1);  // from_chars refuses a '+' sign
    double value = 0;
    const auto [end, error] = std::from_chars(s.data(), s.data() + s.size(), value);
    if (error != std::errc() || end != s.data() + s.size() || !std::isfinite(value)) {
      Fail("'" + std::string(tokens_[i]) + "' is not a finite number (" + std::string(what) + ")",
           "correct the number on this line, or " + kRegenerate);
    }
    return value;
  }

  std::string Where() const { return path_ + ":" + std::to_string(line_number_); }
  int line_number() const { return line_number_; }

  [[noreturn]] void Fail(const std::string& what, const std::string& fix) const {
    throw Error(what, Where(), fix);
  }

 private:
  void Tokenize() {
    tokens_.clear();
    const std::string_view view = line_;
    size_t i = 0;
    while (i < view.size()) {
      const size_t start = view.find_first_not_of(" \t\r", i);
      if (start == std::string_view::npos) break;
      const size_t stop = std::min(view.find_first_of(" \t\r", start), view.size());
      tokens_.push_back(view.substr(start, stop - start));
      i = stop;
    }
  }

  // A .msh file, ASCII or binary, starts with the text line $MeshFormat: a
  // file whose first line is not text is not one (and, read by lines, could
  // take gigabytes to reach its first line end).
  void RequireTextStart() {
    char start[256];
    in_.read(start, sizeof start);
    const size_t size = static_cast<size_t>(in_.gcount());
    const size_t line_end = std::find(start, start + size, '\n') - start;
    if ((line_end == size && size == sizeof start) || FirstBinaryByte(start, line_end) < line_end) {
      throw Error("the mesh file is not a Gmsh .msh file (its first line is not text)", path_ + ":1",
                  "check the path: give a Gmsh .msh file (gmsh -3 model.geo -format msh41)");
    }
    in_.clear();
    in_.seekg(0);
  }

  std::string path_;
  std::ifstream in_;
  std::string line_;
  int line_number_ = 0;
  std::vector<std::string_view> tokens_;
};

struct ElementType {
  int type;
  int num_nodes;
  int dim;
  const char* name;
};

// Gmsh's standard element types (Gmsh reference manual, "MSH file format").
constexpr ElementType kElementTypes[] = {
    {1, 2, 1, "2-node line"},
    {2, 3, 2, "3-node triangle"},
    {3, 4, 2, "4-node quadrangle"},
    {4, 4, 3, "4-node tetrahedron"},
    {5, 8, 3, "8-node hexahedron"},
    {6, 6, 3, "6-node prism"},
    {7, 5, 3, "5-node pyramid"},
    {8, 3, 1, "3-node second-order line"},
    {9, 6, 2, "6-node second-order triangle"},
    {10, 9, 2, "9-node second-order quadrangle"},
    {11, 10, 3, "10-node second-order tetrahedron"},
    {12, 27, 3, "27-node second-order hexahedron"},
    {13, 18, 3, "18-node second-order prism"},
    {14, 14, 3, "14-node second-order pyramid"},
    {15, 1, 0, "1-node point"},
    {16, 8, 2, "8-node second-order quadrangle"},
    {17, 20, 3, "20-node second-order hexahedron"},
    {18, 15, 3, "15-node second-order prism"},
    {19, 13, 3, "13-node second-order pyramid"},
    {20, 9, 2, "9-node third-order incomplete triangle"},
    {21, 10, 2, "10-node third-order triangle"},
    {22, 12, 2, "12-node fourth-order incomplete triangle"},
    {23, 15, 2, "15-node fourth-order triangle"},
    {24, 15, 2, "15-node fifth-order incomplete triangle"},
    {25, 21, 2, "21-node fifth-order triangle"},
    {26, 4, 1, "4-node third-order line"},
    {27, 5, 1, "5-node fourth-order line"},
    {28, 6, 1, "6-node fifth-order line"},
    {29, 20, 3, "20-node third-order tetrahedron"},
    {30, 35, 3, "35-node fourth-order tetrahedron"},
    {31, 56, 3, "56-node fifth-order tetrahedron"},
    {92, 64, 3, "64-node third-order hexahedron"},
    {93, 125, 3, "125-node fourth-order hexahedron"},
};
constexpr int kTetrahedron = 4;

// The type of an element the mesh can use: a tetrahedron, or a lower-dimensional
// element that may carry a physical group.
const ElementType& UsableElementType(const LineReader& in, long long type) {
  const auto* found = std::find_if(std::begin(kElementTypes), std::end(kElementTypes),
                                   [type](const ElementType& t) { return t.type == type; });
  if (found == std::end(kElementTypes)) {
    in.Fail("unknown Gmsh element type " + std::to_string(type), kRemesh);
  }
  if (found->dim == 3 && found->type != kTetrahedron) {
    in.Fail("element type " + std::to_string(type) + " (" + found->name +
                ") is not supported: only 4-node tetrahedra (type 4) make a mesh",
            kRemesh);
  }
  return *found;
}

using DimTag = std::pair<int, long long>;

// Node ids and tetrahedron ids that belong to one physical group (format 2.2)
// or to one Gmsh entity (format 4.1, whose physical groups are per entity).
struct Members {
  std::vector<int> nodes;
  std::vector<int> tets;
};

// Everything read from the file, before it becomes a TetMesh.
struct MshContent {
  int major_version = 0;
  std::map<DimTag, std::string> physical_names;
  std::map<DimTag, std::vector<long long>> entity_physicals;  // format 4.1 only
  std::vector<double> xyz;                                    // 3 per node, file order
  std::unordered_map<long long, int> node_id;                 // the file's tag -> id
  std::vector<int> tets;                                      // 4 node ids per tetrahedron
  std::vector<long long> tet_tags;                            // the file's tag of each tetrahedron
  std::vector<int> tet_lines;                                 // the line that first defines it
  std::unordered_map<long long, int> tet_of_tag;
  std::map<DimTag, Members> members;
  bool has_nodes = false;
  bool has_elements = false;
};

void ReadMeshFormat(LineReader& in, MshContent* content) {
  if (!in.Next()) in.Fail("the file is empty", kRegenerate);
  if (in.token(0) != "$MeshFormat") {
    in.Fail("a .msh file starts with $MeshFormat, found '" + in.line() + "'",
            "check that this is a Gmsh .msh file, or " + kRegenerate);
  }
  in.NextIn("$MeshFormat");
  in.RequireTokens(3, "the format version, file type and data size");
  const std::string_view version = in.token(0);
  if (version == "4.1") {
    content->major_version = 4;
  } else if (version == "2" || version == "2.0" || version == "2.1" || version == "2.2") {
    content->major_version = 2;
  } else {
    in.Fail("unsupported .msh format version " + std::string(version) + " (2.2 and 4.1 are read)",
            "convert it: gmsh old.msh -save -format msh41 -o new.msh");
  }
  if (in.token(1) != "0") {
    in.Fail("binary .msh files are not read",
            "convert it to ASCII: gmsh in.msh -save -format msh41 -o ascii.msh");
  }
  in.ExpectEnd("$MeshFormat");
}

void ReadPhysicalNames(LineReader& in, MshContent* content) {
  in.NextIn("$PhysicalNames");
  const long long count = in.Integer(0, "number of physical names");
  for (long long i = 0; i < count; ++i) {
    in.NextEntry("$PhysicalNames");
    const int dim = static_cast<int>(in.Integer(0, "physical group dimension"));
    const long long tag = in.Integer(1, "physical group tag");
    const size_t open = in.line().find('"');
    const size_t close = in.line().rfind('"');
    if (open == std::string::npos || close == open) {
      in.Fail("expected a quoted physical group name",
              "write the name in double quotes: 2 1 \"top\"");
    }
    content->physical_names[{dim, tag}] = in.line().substr(open + 1, close - open - 1);
  }
  in.ExpectEnd("$PhysicalNames");
}

// Format 4.1 attaches physical groups to entities (points, curves, surfaces,
// volumes); elements then name only their entity.
void ReadEntities(LineReader& in, MshContent* content) {
  in.NextIn("$Entities");
  long long counts[4];
  for (int dim = 0; dim < 4; ++dim) counts[dim] = in.Integer(dim, "number of entities");
  for (int dim = 0; dim < 4; ++dim) {
    // A point lists its position, other entities their bounding box.
    const size_t physicals_at = dim == 0 ? 4 : 7;
    for (long long i = 0; i < counts[dim]; ++i) {
      in.NextEntry("$Entities");
      const long long tag = in.Integer(0, "entity tag");
      const long long num_physicals = in.Integer(physicals_at, "number of physical tags");
      std::vector<long long>& physicals = content->entity_physicals[{dim, tag}];
      for (long long k = 0; k < num_physicals; ++k) {
        physicals.push_back(in.Integer(physicals_at + 1 + k, "physical tag"));
      }
    }
  }
  in.ExpectEnd("$Entities");
}

// Gives the next node id to a file's node tag; refuses a repeated tag.
void AddNodeTag(const LineReader& in, long long tag, MshContent* content) {
  const int id = static_cast<int>(content->node_id.size());
  if (!content->node_id.emplace(tag, id).second) {
    in.Fail("node tag " + std::to_string(tag) + " appears twice",
            "give every node its own tag, or " + kRegenerate);
  }
}

void AddCoordinates(const LineReader& in, size_t first, MshContent* content) {
  for (size_t k = 0; k < 3; ++k) content->xyz.push_back(in.Real(first + k, "node coordinate"));
}

void ReadNodes2(LineReader& in, MshContent* content) {
  in.NextIn("$Nodes");
  const long long count = in.Integer(0, "number of nodes");
  for (long long i = 0; i < count; ++i) {
    in.NextEntry("$Nodes");
    if (in.size() != 4) {
      in.Fail("a node line holds its tag and x y z", "correct the line, or " + kRegenerate);
    }
    AddNodeTag(in, in.Integer(0, "node tag"), content);
    AddCoordinates(in, 1, content);
  }
  in.ExpectEnd("$Nodes");
}

// Format 4.1 lists nodes in entity blocks: all the block's tags, then all its
// coordinates (followed by parametric coordinates when the block has them).
void ReadNodes4(LineReader& in, MshContent* content) {
  in.NextIn("$Nodes");
  const long long num_blocks = in.Integer(0, "number of node blocks");
  const long long num_nodes = in.Integer(1, "number of nodes");
  for (long long b = 0; b < num_blocks; ++b) {
    in.NextEntry("$Nodes");
    const long long dim = in.Integer(0, "entity dimension");
    const bool parametric = in.Integer(2, "parametric flag") != 0;
    const long long count = in.Integer(3, "number of nodes in block");
    for (long long i = 0; i < count; ++i) {
      in.NextEntry("$Nodes");
      if (in.size() != 1) {
        in.Fail("expected one node tag on this line", "correct the line, or " + kRegenerate);
      }
      AddNodeTag(in, in.Integer(0, "node tag"), content);
    }
    const size_t values = 3 + (parametric && dim < 3 ? dim : 0);
    for (long long i = 0; i < count; ++i) {
      in.NextEntry("$Nodes");
      if (in.size() != values) {
        in.Fail("expected " + std::to_string(values) + " coordinates on this line, found " +
                    std::to_string(in.size()),
                "correct the line, or " + kRegenerate);
      }
      AddCoordinates(in, 0, content);
    }
  }
  if (static_cast<long long>(content->node_id.size()) != num_nodes) {
    in.Fail("the $Nodes header counts " + std::to_string(num_nodes) +
                " nodes but its blocks hold " + std::to_string(content->node_id.size()),
            "correct the count in the section header, or " + kRegenerate);
  }
  in.ExpectEnd("$Nodes");
}

// Adds the element whose node tags are the line's tokens from `first` on.
// A repeated tetrahedron (format 2.2 writes an element once per physical
// group it is in) joins `members` without being added twice.
void AddElement(const LineReader& in, const ElementType& type, long long tag, size_t first,
                Members* members, MshContent* content) {
  if (in.size() != first + type.num_nodes) {
    in.Fail("element " + std::to_string(tag) + " (" + type.name + ") should list " +
                std::to_string(type.num_nodes) + " nodes but lists " +
                std::to_string(in.size() - first),
            "correct the element line, or " + kRegenerate);
  }
  std::vector<int> ids(type.num_nodes);
  for (int k = 0; k < type.num_nodes; ++k) {
    const long long node_tag = in.Integer(first + k, "node tag");
    const auto found = content->node_id.find(node_tag);
    if (found == content->node_id.end()) {
      in.Fail("element " + std::to_string(tag) + " refers to node " + std::to_string(node_tag) +
                  ", which the $Nodes section does not define",
              "correct the node tag, or " + kRegenerate);
    }
    ids[k] = found->second;
  }
  int tet = -1;
  if (type.type == kTetrahedron) {
    const int next = static_cast<int>(content->tets.size() / 4);
    const auto [it, added] = content->tet_of_tag.emplace(tag, next);
    tet = it->second;
    if (added) {
      content->tets.insert(content->tets.end(), ids.begin(), ids.end());
      content->tet_tags.push_back(tag);
      content->tet_lines.push_back(in.line_number());
    } else if (!std::equal(ids.begin(), ids.end(), content->tets.begin() + 4 * tet)) {
      in.Fail("element tag " + std::to_string(tag) + " is used by two different tetrahedra",
              "give every element its own tag, or " + kRegenerate);
    }
  }
  if (members) {
    members->nodes.insert(members->nodes.end(), ids.begin(), ids.end());
    if (tet >= 0) members->tets.push_back(tet);
  }
}

void RequireNodesFirst(const LineReader& in, const MshContent& content) {
  if (!content.has_nodes) {
    in.Fail("$Elements comes before $Nodes", "put the $Nodes section first, or " + kRegenerate);
  }
}

// Format 2.2: one element per line, "tag type num_tags tags... nodes...", the
// first tag being the physical group (0 for none).
void ReadElements2(LineReader& in, MshContent* content) {
  RequireNodesFirst(in, *content);
  in.NextIn("$Elements");
  const long long count = in.Integer(0, "number of elements");
  for (long long i = 0; i < count; ++i) {
    in.NextEntry("$Elements");
    const long long tag = in.Integer(0, "element tag");
    const ElementType& type = UsableElementType(in, in.Integer(1, "element type"));
    const long long num_tags = in.Integer(2, "number of element tags");
    const long long physical = num_tags > 0 ? in.Integer(3, "physical tag") : 0;
    Members* members = physical != 0 ? &content->members[{type.dim, physical}] : nullptr;
    AddElement(in, type, tag, 3 + std::max(num_tags, 0LL), members, content);
  }
  in.ExpectEnd("$Elements");
}

// Format 4.1: entity blocks "dim entity type count", then "tag nodes..." lines.
void ReadElements4(LineReader& in, MshContent* content) {
  RequireNodesFirst(in, *content);
  in.NextIn("$Elements");
  const long long num_blocks = in.Integer(0, "number of element blocks");
  for (long long b = 0; b < num_blocks; ++b) {
    in.NextEntry("$Elements");
    const int dim = static_cast<int>(in.Integer(0, "entity dimension"));
    const long long entity = in.Integer(1, "entity tag");
    const ElementType& type = UsableElementType(in, in.Integer(2, "element type"));
    const long long count = in.Integer(3, "number of elements in block");
    Members* members = &content->members[{dim, entity}];
    for (long long i = 0; i < count; ++i) {
      in.NextEntry("$Elements");
      AddElement(in, type, in.Integer(0, "element tag"), 1, members, content);
    }
  }
  in.ExpectEnd("$Elements");
}

void SkipSection(LineReader& in, std::string_view section) {
  const std::string end = "$End" + std::string(section.substr(1));
  do {
    in.NextIn(section);
  } while (in.token(0) != end);
}

MshContent ReadContent(const std::string& path) {
  LineReader in(path);
  MshContent content;
  ReadMeshFormat(in, &content);
  while (in.Next()) {
    const std::string section(in.token(0));
    if (section.front() != '$') {
      in.Fail("expected a section such as $Nodes, found '" + in.line() + "'", kRegenerate);
    }
    if (section == "$PhysicalNames") {
      ReadPhysicalNames(in, &content);
    } else if (section == "$Entities" && content.major_version == 4) {
      ReadEntities(in, &content);
    } else if (section == "$Nodes") {
      content.major_version == 4 ? ReadNodes4(in, &content) : ReadNodes2(in, &content);
      content.has_nodes = true;
    } else if (section == "$Elements") {
      content.major_version == 4 ? ReadElements4(in, &content) : ReadElements2(in, &content);
      content.has_elements = true;
    } else if (section == "$PartitionedEntities") {
      in.Fail("partitioned meshes are not read", "save the mesh unpartitioned, or " + kRegenerate);
    } else {
      SkipSection(in, section);  // $Periodic, $NodeData, ...: nothing the mesh needs
    }
  }
  if (!content.has_elements) {
    in.Fail(
        std::string("the file has no ") + (content.has_nodes ? "$Elements" : "$Nodes") + " section",
        "the file is truncated or not a mesh; " + kRegenerate);
  }
  return content;
}

// Physical groups by (dimension, tag), whichever way the file attached them.
std::map<DimTag, Members> PhysicalGroups(MshContent* content) {
  if (content->major_version == 2) return std::move(content->members);
  std::map<DimTag, Members> groups;
  for (auto& [entity, members] : content->members) {
    for (long long physical : content->entity_physicals[entity]) {
      Members& group = groups[{entity.first, physical}];
      group.nodes.insert(group.nodes.end(), members.nodes.begin(), members.nodes.end());
      group.tets.insert(group.tets.end(), members.tets.begin(), members.tets.end());
    }
  }
  return groups;
}

void SortUnique(std::vector<int>* ids) {
  std::sort(ids->begin(), ids->end());
  ids->erase(std::unique(ids->begin(), ids->end()), ids->end());
}

void AddSets(MshContent* content, sim::TetMesh* mesh) {
  for (auto& [group, members] : PhysicalGroups(content)) {
    const auto named = content->physical_names.find(group);
    const std::string name =
        named != content->physical_names.end()
            ? named->second
            : "physical_" + std::to_string(group.first) + "_" + std::to_string(group.second);
    std::vector<int>& nodes = mesh->node_sets[name];
    nodes.insert(nodes.end(), members.nodes.begin(), members.nodes.end());
    if (group.first == 3) {
      std::vector<int>& tets = mesh->element_sets[name];
      tets.insert(tets.end(), members.tets.begin(), members.tets.end());
    }
  }
  for (auto& [name, ids] : mesh->node_sets) SortUnique(&ids);
  for (auto& [name, ids] : mesh->element_sets) SortUnique(&ids);
}

}  // namespace

sim::TetMesh ReadGmsh(const std::string& path, double metres_per_unit) {
  if (!(metres_per_unit > 0) || !std::isfinite(metres_per_unit)) {
    throw Error(
        "metres per unit must be positive and finite, got " + std::to_string(metres_per_unit), path,
        "pass the mesh's length unit in metres, e.g. 1e-3 for millimetres");
  }
  MshContent content = ReadContent(path);
  const int num_tets = static_cast<int>(content.tets.size() / 4);
  if (num_tets == 0) {
    throw Error("the mesh has no 4-node tetrahedra", path,
                "mesh the volume (gmsh -3 model.geo); when the model has physical groups, put the "
                "volume in "
                "one, as Gmsh then saves only elements that belong to a physical group");
  }
  sim::TetMesh mesh;
  mesh.source = path;
  const auto num_nodes = static_cast<Eigen::Index>(content.node_id.size());
  mesh.X_m = Eigen::Map<const Eigen::Matrix3Xd>(content.xyz.data(), 3, num_nodes) * metres_per_unit;
  mesh.tets =
      Eigen::Map<const Eigen::Matrix<int, 4, Eigen::Dynamic>>(content.tets.data(), 4, num_tets);
  mesh.element_tags = std::move(content.tet_tags);
  mesh.element_lines = std::move(content.tet_lines);
  AddSets(&content, &mesh);
  const int dropped = sim::RemoveUnusedNodes(&mesh);
  const int flipped = sim::OrientElements(&mesh, sim::Orientation::kReorient);
  Logger("io").info(
      "read {} (msh {}): {} nodes ({} unused dropped), {} tetrahedra ({} reoriented), {} node "
      "sets, {} element sets",
      path, content.major_version == 4 ? "4.1" : "2.2", mesh.num_nodes(), dropped, mesh.num_tets(),
      flipped, mesh.node_sets.size(), mesh.element_sets.size());
  return mesh;
}

}  // namespace dg::io
