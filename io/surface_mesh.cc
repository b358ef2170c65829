#include "io/surface_mesh.h"

#include <array>
#include <bit>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <vector>

#include "sim/error.h"

namespace dg::io {
namespace {

// Binary PLY is written and read as the machine stores numbers.
static_assert(std::endian::native == std::endian::little, "PLY I/O assumes a little-endian host");

// A text file read one line at a time, split into whitespace-separated
// tokens, so that every error can name the line it is on. Opened in binary
// mode so that a binary PLY body can follow its text header.
class TextLines {
 public:
  TextLines(const std::string& path, const std::string& kind)
      : path_(path), in_(path, std::ios::binary) {
    if (!in_) throw Error("cannot open " + kind + " file", path, "check the path");
  }

  // Moves to the next line that is neither blank nor a '#' comment; false at the end.
  bool Next() {
    std::string line;
    while (std::getline(in_, line)) {
      ++line_number_;
      tokens_.clear();
      std::istringstream split(line);
      for (std::string token; split >> token;) tokens_.push_back(token);
      if (!tokens_.empty() && tokens_[0][0] != '#') return true;
    }
    return false;
  }

  size_t size() const { return tokens_.size(); }
  const std::string& operator[](size_t i) const { return tokens_[i]; }

  double Number(size_t i) const {
    double value;
    if (!Parse(tokens_[i], &value)) Fail("expected a number, found '" + tokens_[i] + "'");
    return value;
  }

  void RequireTokens(size_t count, const std::string& what) const {
    if (tokens_.size() < count) {
      Fail(what + " needs " + std::to_string(count - 1) + " values, found " +
           std::to_string(tokens_.size() - 1));
    }
  }

  [[noreturn]] void Fail(
      const std::string& problem,
      const std::string& fix = "correct the line, or export the file again") const {
    throw Error(problem, where(), fix);
  }

  std::string where() const { return path_ + ":" + std::to_string(line_number_); }
  const std::string& path() const { return path_; }
  std::istream& stream() { return in_; }

  template <typename Number>
  static bool Parse(const std::string& token, Number* value) {
    const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), *value);
    return error == std::errc() && end == token.data() + token.size();
  }

 private:
  std::string path_;
  std::ifstream in_;
  int line_number_ = 0;
  std::vector<std::string> tokens_;
};

// Splits a polygon (vertex indices, in order) into the fan (0, i, i + 1).
void AppendFan(const std::vector<int>& polygon, std::vector<Eigen::Vector3i>* triangles) {
  for (size_t i = 1; i + 1 < polygon.size(); ++i) {
    triangles->emplace_back(polygon[0], polygon[i], polygon[i + 1]);
  }
}

template <int Rows, typename Scalar>
Eigen::Matrix<Scalar, Rows, Eigen::Dynamic> Columns(
    const std::vector<Eigen::Matrix<Scalar, Rows, 1>>& columns) {
  Eigen::Matrix<Scalar, Rows, Eigen::Dynamic> matrix(Rows, columns.size());
  for (size_t i = 0; i < columns.size(); ++i) matrix.col(i) = columns[i];
  return matrix;
}

void CheckMesh(const SurfaceMesh& mesh, const SurfaceFileOptions& options) {
  DG_CHECK(options.metres_per_unit > 0);
  DG_CHECK(mesh.uvs.cols() == 0 || mesh.uvs.cols() == mesh.num_vertices());
  DG_CHECK(mesh.normals.cols() == 0 || mesh.normals.cols() == mesh.num_vertices());
  DG_CHECK(mesh.num_triangles() == 0 ||
           (mesh.triangles.minCoeff() >= 0 && mesh.triangles.maxCoeff() < mesh.num_vertices()));
}

// Shortest text that reads back to the same double.
void AppendNumber(double value, std::string* text) {
  char buffer[32];
  const auto end = std::to_chars(buffer, buffer + sizeof(buffer), value).ptr;
  text->push_back(' ');
  text->append(buffer, end);
}

void WriteFile(const std::string& path, const std::string& contents) {
  std::ofstream out(path, std::ios::binary);
  out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
  out.close();
  if (!out)
    throw Error("cannot write file", path, "check that the directory exists and is writable");
}

std::string UnitsComment(const SurfaceFileOptions& options) {
  std::string comment = "dynaguide surface mesh; metres per unit:";
  AppendNumber(options.metres_per_unit, &comment);
  return comment;
}

// ---------------------------------------------------------------- OBJ

// One corner of an OBJ face: 0-based indices of its v, vt and vn (-1: none).
struct Corner {
  int v, vt, vn;
  auto operator<=>(const Corner&) const = default;
};

// An index of an f line: 1-based, or negative counting back from the end of
// the list read so far.
int ResolveIndex(const TextLines& lines, const std::string& text, size_t count, const char* list) {
  int index = 0;
  if (!TextLines::Parse(text, &index) || index == 0) {
    lines.Fail("expected a non-zero " + std::string(list) + " index, found '" + text + "'");
  }
  const long resolved = index > 0 ? index - 1L : static_cast<long>(count) + index;
  if (resolved < 0 || resolved >= static_cast<long>(count)) {
    lines.Fail(std::string(list) + " index " + text + " refers to none of the " +
               std::to_string(count) + " defined before this line");
  }
  return static_cast<int>(resolved);
}

// v, v/vt, v//vn or v/vt/vn.
Corner ParseCorner(const TextLines& lines, const std::string& token, size_t num_v, size_t num_vt,
                   size_t num_vn) {
  std::array<std::string, 3> parts;
  size_t part = 0;
  for (char c : token) {
    if (c != '/') {
      parts[part] += c;
    } else if (++part == parts.size()) {
      lines.Fail("face corner '" + token + "' has more than three indices");
    }
  }
  return {ResolveIndex(lines, parts[0], num_v, "v"),
          parts[1].empty() ? -1 : ResolveIndex(lines, parts[1], num_vt, "vt"),
          parts[2].empty() ? -1 : ResolveIndex(lines, parts[2], num_vn, "vn")};
}

// What an OBJ file lists: separate v, vt and vn arrays and faces of corners.
struct ObjContents {
  std::vector<Eigen::Vector3d> v;
  std::vector<Eigen::Vector2d> vt;
  std::vector<Eigen::Vector3d> vn;
  std::vector<std::vector<Corner>> faces;
};

ObjContents ParseObj(const std::string& path) {
  ObjContents obj;
  TextLines lines(path, "OBJ");
  while (lines.Next()) {
    const std::string& statement = lines[0];
    if (statement == "v" || statement == "vn") {
      lines.RequireTokens(4, statement);  // v may carry a w or a colour after x y z
      auto& list = statement == "v" ? obj.v : obj.vn;
      list.emplace_back(lines.Number(1), lines.Number(2), lines.Number(3));
    } else if (statement == "vt") {
      lines.RequireTokens(2, statement);
      obj.vt.emplace_back(lines.Number(1), lines.size() > 2 ? lines.Number(2) : 0.0);
    } else if (statement == "f") {
      lines.RequireTokens(4, "a face");
      std::vector<Corner>& face = obj.faces.emplace_back();
      for (size_t i = 1; i < lines.size(); ++i) {
        face.push_back(ParseCorner(lines, lines[i], obj.v.size(), obj.vt.size(), obj.vn.size()));
      }
    }
  }
  return obj;
}

// One mesh vertex per distinct (v, vt, vn) corner. A v used with a single
// combination keeps its index, so that files without seams keep their
// vertex order; further combinations become copies appended at the end.
SurfaceMesh ToSurfaceMesh(const ObjContents& obj) {
  bool all_vt = !obj.faces.empty(), all_vn = !obj.faces.empty();
  for (const auto& face : obj.faces) {
    for (const Corner& corner : face) {
      all_vt = all_vt && corner.vt >= 0;
      all_vn = all_vn && corner.vn >= 0;
    }
  }
  std::vector<Eigen::Vector3d> vertices = obj.v, normals(obj.v.size(), Eigen::Vector3d::Zero());
  std::vector<Eigen::Vector2d> uvs(obj.v.size(), Eigen::Vector2d::Zero());
  std::vector<bool> used(obj.v.size(), false);
  std::map<Corner, int> vertex_of;
  std::vector<Eigen::Vector3i> triangles;
  for (const auto& face : obj.faces) {
    std::vector<int> polygon;
    for (Corner corner : face) {
      corner = {corner.v, all_vt ? corner.vt : -1, all_vn ? corner.vn : -1};
      auto [it, inserted] = vertex_of.try_emplace(corner, corner.v);
      if (inserted) {
        if (used[corner.v]) {
          it->second = static_cast<int>(vertices.size());
          vertices.push_back(obj.v[corner.v]);
          uvs.emplace_back();
          normals.emplace_back();
        }
        used[corner.v] = true;
        if (all_vt) uvs[it->second] = obj.vt[corner.vt];
        if (all_vn) normals[it->second] = obj.vn[corner.vn];
      }
      polygon.push_back(it->second);
    }
    AppendFan(polygon, &triangles);
  }
  SurfaceMesh mesh;
  mesh.vertices_m = Columns(vertices);
  mesh.triangles = Columns(triangles);
  if (all_vt) mesh.uvs = Columns(uvs);
  if (all_vn) mesh.normals = Columns(normals);
  return mesh;
}

void WriteMtl(const std::string& path, const std::string& texture_image) {
  WriteFile(path, "newmtl surface\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nd 1\nillum 1\nmap_Kd " +
                      texture_image + "\n");
}

// ---------------------------------------------------------------- PLY

enum class PlyFormat { kAscii, kBinaryLittleEndian };

struct PlyScalar {
  enum Kind { kSigned, kUnsigned, kFloat } kind;
  int bytes;
};

std::optional<PlyScalar> ParsePlyScalar(const std::string& name) {
  static const std::map<std::string, PlyScalar> kTypes = {
      {"char", {PlyScalar::kSigned, 1}},     {"int8", {PlyScalar::kSigned, 1}},
      {"uchar", {PlyScalar::kUnsigned, 1}},  {"uint8", {PlyScalar::kUnsigned, 1}},
      {"short", {PlyScalar::kSigned, 2}},    {"int16", {PlyScalar::kSigned, 2}},
      {"ushort", {PlyScalar::kUnsigned, 2}}, {"uint16", {PlyScalar::kUnsigned, 2}},
      {"int", {PlyScalar::kSigned, 4}},      {"int32", {PlyScalar::kSigned, 4}},
      {"uint", {PlyScalar::kUnsigned, 4}},   {"uint32", {PlyScalar::kUnsigned, 4}},
      {"float", {PlyScalar::kFloat, 4}},     {"float32", {PlyScalar::kFloat, 4}},
      {"double", {PlyScalar::kFloat, 8}},    {"float64", {PlyScalar::kFloat, 8}}};
  const auto it = kTypes.find(name);
  return it == kTypes.end() ? std::nullopt : std::optional(it->second);
}

struct PlyProperty {
  std::string name;
  PlyScalar type;
  std::optional<PlyScalar> count_type;  // set for a list property
};

struct PlyElement {
  std::string name;
  size_t count;
  std::vector<PlyProperty> properties;
};

struct PlyHeader {
  PlyFormat format;
  std::vector<PlyElement> elements;
};

PlyScalar ScalarType(const TextLines& lines, size_t token) {
  const std::optional<PlyScalar> type = ParsePlyScalar(lines[token]);
  if (!type) lines.Fail("unknown PLY type '" + lines[token] + "'");
  return *type;
}

PlyHeader ParsePlyHeader(TextLines& lines) {
  if (!lines.Next() || lines[0] != "ply") lines.Fail("not a PLY file: the first line is not 'ply'");
  PlyHeader header;
  bool has_format = false;
  while (lines.Next() && lines[0] != "end_header") {
    if (lines[0] == "format") {
      lines.RequireTokens(3, "format");
      if (lines[1] == "ascii") {
        header.format = PlyFormat::kAscii;
      } else if (lines[1] == "binary_little_endian") {
        header.format = PlyFormat::kBinaryLittleEndian;
      } else {
        lines.Fail("PLY format '" + lines[1] + "' is not read",
                   "export as ASCII or binary little-endian PLY");
      }
      has_format = true;
    } else if (lines[0] == "element") {
      lines.RequireTokens(3, "element");
      size_t count = 0;
      if (!TextLines::Parse(lines[2], &count))
        lines.Fail("expected a count, found '" + lines[2] + "'");
      header.elements.push_back({lines[1], count, {}});
    } else if (lines[0] == "property") {
      if (header.elements.empty()) lines.Fail("property before any element");
      const bool list = lines.size() > 1 && lines[1] == "list";
      lines.RequireTokens(list ? 5 : 3, "property");
      PlyProperty property{lines[lines.size() - 1], ScalarType(lines, list ? 3 : 1), std::nullopt};
      if (list) property.count_type = ScalarType(lines, 2);
      header.elements.back().properties.push_back(property);
    } else if (lines[0] != "comment" && lines[0] != "obj_info") {
      lines.Fail("unknown PLY header line '" + lines[0] + "'");
    }
  }
  if (lines.size() == 0 || lines[0] != "end_header") lines.Fail("the header has no end_header");
  if (!has_format) lines.Fail("the header has no format line");
  return header;
}

// Reads the values of a PLY body one at a time, from text lines (one element
// instance per line) or from little-endian binary.
class PlyValues {
 public:
  PlyValues(TextLines* lines, PlyFormat format) : lines_(lines), format_(format) {}

  void Begin(const std::string& element, size_t index) {
    element_ = element;
    index_ = index;
    if (format_ == PlyFormat::kBinaryLittleEndian) return;
    if (!lines_->Next()) Fail("the file ends before this element");
    token_ = 0;
  }

  double Next(const PlyScalar& type) {
    if (format_ == PlyFormat::kAscii) {
      if (token_ >= lines_->size()) Fail("too few values on the line");
      return lines_->Number(token_++);
    }
    unsigned char bytes[8];
    if (!lines_->stream().read(reinterpret_cast<char*>(bytes), type.bytes)) {
      Fail("the file ends inside this element");
    }
    return Decode(bytes, type);
  }

  [[noreturn]] void Fail(const std::string& problem) const {
    const std::string where =
        format_ == PlyFormat::kAscii
            ? lines_->where()
            : lines_->path() + ": element " + element_ + " " + std::to_string(index_);
    throw Error(problem + " (" + element_ + " " + std::to_string(index_) + ")", where,
                "correct the file, or export it again");
  }

 private:
  template <typename T>
  static double As(const unsigned char* bytes) {
    T value;
    std::memcpy(&value, bytes, sizeof(T));
    return static_cast<double>(value);
  }

  static double Decode(const unsigned char* bytes, const PlyScalar& type) {
    switch (type.kind) {
      case PlyScalar::kSigned:
        return type.bytes == 1   ? As<std::int8_t>(bytes)
               : type.bytes == 2 ? As<std::int16_t>(bytes)
                                 : As<std::int32_t>(bytes);
      case PlyScalar::kUnsigned:
        return type.bytes == 1   ? As<std::uint8_t>(bytes)
               : type.bytes == 2 ? As<std::uint16_t>(bytes)
                                 : As<std::uint32_t>(bytes);
      case PlyScalar::kFloat:
        return type.bytes == 4 ? As<float>(bytes) : As<double>(bytes);
    }
    return 0;  // unreachable: every kind returns
  }

  TextLines* lines_;
  PlyFormat format_;
  std::string element_;
  size_t index_ = 0;
  size_t token_ = 0;
};

// Where a vertex property goes: coordinate `component` of x (0), n (1) or uv (2).
std::optional<std::pair<int, int>> VertexSlot(const std::string& name) {
  static const std::map<std::string, std::pair<int, int>> kSlots = {
      {"x", {0, 0}},         {"y", {0, 1}},        {"z", {0, 2}},         {"nx", {1, 0}},
      {"ny", {1, 1}},        {"nz", {1, 2}},       {"s", {2, 0}},         {"t", {2, 1}},
      {"u", {2, 0}},         {"v", {2, 1}},        {"texture_u", {2, 0}}, {"texture_v", {2, 1}},
      {"texture_s", {2, 0}}, {"texture_t", {2, 1}}};
  const auto it = kSlots.find(name);
  return it == kSlots.end() ? std::nullopt : std::optional(it->second);
}

int ToIndex(double value, PlyValues& values) {
  if (value < 0 || value != static_cast<int>(value)) {
    values.Fail("expected a non-negative integer, found " + std::to_string(value));
  }
  return static_cast<int>(value);
}

// The vertex attributes (x, n, uv) and faces read from a PLY body.
struct PlyContents {
  std::array<Eigen::MatrixXd, 3> attributes{Eigen::MatrixXd(3, 0), Eigen::MatrixXd(3, 0),
                                            Eigen::MatrixXd(2, 0)};
  std::array<int, 3> components_found{};
  std::vector<Eigen::Vector3i> triangles;
};

// Reads every instance of an element, handing each property's values (one,
// or a list's) to `use(instance, property, values)`.
template <typename Use>
void ReadPlyElement(const PlyElement& element, PlyValues& values, Use use) {
  for (size_t i = 0; i < element.count; ++i) {
    values.Begin(element.name, i);
    for (const PlyProperty& property : element.properties) {
      const int count =
          property.count_type ? ToIndex(values.Next(*property.count_type), values) : 1;
      std::vector<double> read(count);
      for (double& value : read) value = values.Next(property.type);
      use(i, property, read);
    }
  }
}

void ReadPlyVertices(const PlyElement& element, PlyValues& values, PlyContents* ply) {
  for (auto& attribute : ply->attributes) attribute.setZero(attribute.rows(), element.count);
  for (const PlyProperty& property : element.properties) {
    if (const auto slot = VertexSlot(property.name); slot && !property.count_type) {
      ++ply->components_found[slot->first];
    }
  }
  ReadPlyElement(element, values,
                 [&](size_t i, const PlyProperty& property, const std::vector<double>& read) {
                   const auto slot = VertexSlot(property.name);
                   if (slot && !property.count_type)
                     ply->attributes[slot->first](slot->second, i) = read[0];
                 });
}

void ReadPlyFaces(const PlyElement& element, size_t num_vertices, PlyValues& values,
                  PlyContents* ply) {
  ReadPlyElement(
      element, values, [&](size_t, const PlyProperty& property, const std::vector<double>& read) {
        if (property.name != "vertex_indices" && property.name != "vertex_index") return;
        if (read.size() < 3) values.Fail("a face needs at least 3 vertices");
        std::vector<int> polygon;
        for (double value : read) {
          polygon.push_back(ToIndex(value, values));
          if (polygon.back() >= static_cast<int>(num_vertices)) {
            values.Fail("vertex index " + std::to_string(polygon.back()) + " is not below the " +
                        std::to_string(num_vertices) + " vertices");
          }
        }
        AppendFan(polygon, &ply->triangles);
      });
}

template <typename T>
void AppendBytes(T value, std::string* bytes) {
  bytes->append(reinterpret_cast<const char*>(&value), sizeof(T));
}

}  // namespace

void WriteObj(const std::string& path, const SurfaceMesh& mesh, const SurfaceFileOptions& options) {
  CheckMesh(mesh, options);
  const double units_per_metre = 1.0 / options.metres_per_unit;
  std::string text = "# " + UnitsComment(options) + "\n";
  if (!options.texture_image.empty()) {
    const std::filesystem::path mtl = std::filesystem::path(path).replace_extension(".mtl");
    WriteMtl(mtl.string(), options.texture_image);
    text += "mtllib " + mtl.filename().string() + "\nusemtl surface\n";
  }
  const auto append_columns = [&](const char* statement, const Eigen::MatrixXd& columns) {
    for (Eigen::Index i = 0; i < columns.cols(); ++i) {
      text += statement;
      for (Eigen::Index r = 0; r < columns.rows(); ++r) AppendNumber(columns(r, i), &text);
      text += '\n';
    }
  };
  append_columns("v", mesh.vertices_m * units_per_metre);
  append_columns("vt", mesh.uvs);
  append_columns("vn", mesh.normals);
  // Every corner's v, vt and vn share its vertex index.
  const bool has_uvs = mesh.uvs.cols() > 0, has_normals = mesh.normals.cols() > 0;
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    text += 'f';
    for (int c = 0; c < 3; ++c) {
      const std::string index = std::to_string(mesh.triangles(c, t) + 1);
      text += ' ' + index;
      if (has_uvs || has_normals) text += '/' + (has_uvs ? index : "");
      if (has_normals) text += '/' + index;
    }
    text += '\n';
  }
  WriteFile(path, text);
}

SurfaceMesh ReadObj(const std::string& path, const SurfaceFileOptions& options) {
  DG_CHECK(options.metres_per_unit > 0);
  SurfaceMesh mesh = ToSurfaceMesh(ParseObj(path));
  mesh.vertices_m *= options.metres_per_unit;
  return mesh;
}

void WritePly(const std::string& path, const SurfaceMesh& mesh, const SurfaceFileOptions& options) {
  CheckMesh(mesh, options);
  const bool has_uvs = mesh.uvs.cols() > 0, has_normals = mesh.normals.cols() > 0;
  std::string bytes = "ply\nformat binary_little_endian 1.0\ncomment " + UnitsComment(options) +
                      "\nelement vertex " + std::to_string(mesh.num_vertices()) +
                      "\nproperty double x\nproperty double y\nproperty double z\n";
  if (has_normals) bytes += "property float nx\nproperty float ny\nproperty float nz\n";
  if (has_uvs) bytes += "property float s\nproperty float t\n";
  bytes += "element face " + std::to_string(mesh.num_triangles()) +
           "\nproperty list uchar int vertex_indices\nend_header\n";
  for (int i = 0; i < mesh.num_vertices(); ++i) {
    for (int r = 0; r < 3; ++r)
      AppendBytes(mesh.vertices_m(r, i) / options.metres_per_unit, &bytes);
    for (int r = 0; has_normals && r < 3; ++r)
      AppendBytes(static_cast<float>(mesh.normals(r, i)), &bytes);
    for (int r = 0; has_uvs && r < 2; ++r) AppendBytes(static_cast<float>(mesh.uvs(r, i)), &bytes);
  }
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    AppendBytes(std::uint8_t{3}, &bytes);
    for (int c = 0; c < 3; ++c)
      AppendBytes(static_cast<std::int32_t>(mesh.triangles(c, t)), &bytes);
  }
  WriteFile(path, bytes);
}

SurfaceMesh ReadPly(const std::string& path, const SurfaceFileOptions& options) {
  DG_CHECK(options.metres_per_unit > 0);
  TextLines lines(path, "PLY");
  const PlyHeader header = ParsePlyHeader(lines);
  PlyValues values(&lines, header.format);
  PlyContents ply;
  size_t num_vertices = 0;
  for (const PlyElement& element : header.elements) {
    if (element.name == "vertex") {
      ReadPlyVertices(element, values, &ply);
      num_vertices = element.count;
    } else if (element.name == "face") {
      ReadPlyFaces(element, num_vertices, values, &ply);
    } else {
      ReadPlyElement(element, values,
                     [](size_t, const PlyProperty&, const std::vector<double>&) {});
    }
  }
  if (ply.components_found[0] != 3) {
    throw Error("the PLY file has no vertex element with x, y and z", path,
                "export the mesh with vertex positions");
  }
  SurfaceMesh mesh;
  mesh.vertices_m = ply.attributes[0] * options.metres_per_unit;
  if (ply.components_found[1] == 3) mesh.normals = ply.attributes[1];
  if (ply.components_found[2] == 2) mesh.uvs = ply.attributes[2];
  mesh.triangles = Columns(ply.triangles);
  return mesh;
}

}  // namespace dg::io
