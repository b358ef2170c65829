#include "io/surface_mesh_reader.h"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>

#include <vtkAlgorithm.h>
#include <vtkCallbackCommand.h>
#include <vtkCellArray.h>
#include <vtkCellArrayIterator.h>
#include <vtkDataArray.h>
#include <vtkExecutive.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkOutputWindow.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkPolyDataReader.h>
#include <vtkSTLReader.h>
#include <vtkSmartPointer.h>
#include <vtkTriangleFilter.h>
#include <vtkXMLPolyDataReader.h>

#include "sim/error.h"

namespace dg::io {
namespace {

enum class Format { kObj, kPly, kStl, kLegacyVtk, kXmlPolyData };

const std::map<std::string, Format>& FormatOfExtension() {
  static const std::map<std::string, Format> kFormats = {{".obj", Format::kObj},
                                                         {".ply", Format::kPly},
                                                         {".stl", Format::kStl},
                                                         {".vtk", Format::kLegacyVtk},
                                                         {".vtp", Format::kXmlPolyData}};
  return kFormats;
}

// CAD and scanner software often write upper-case extensions (.STL).
std::string LowerExtension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

const char* FormatName(Format format) {
  switch (format) {
    case Format::kObj: return "OBJ";
    case Format::kPly: return "PLY";
    case Format::kStl: return "STL";
    case Format::kLegacyVtk: return "legacy VTK";
    case Format::kXmlPolyData: return "VTK XML polydata";
  }
  return "";  // unreachable: every format is named
}

// VTK reports a reader's errors and warnings as events, and prints them when
// nobody listens; listening collects them for the dg::Error instead. Its
// readers' helpers report through the global output window (the legacy
// reader's "Error reading binary data" of a file cut short), which is
// replaced for the read. Any error or warning fails the read, even when some
// triangles came out.
class VtkMessages {
 public:
  VtkMessages() {
    callback_->SetClientData(this);
    callback_->SetCallback(&VtkMessages::Collect);
    window_->messages = this;
    previous_window_ = vtkOutputWindow::GetInstance();
    vtkOutputWindow::SetInstance(window_);
  }
  ~VtkMessages() { vtkOutputWindow::SetInstance(previous_window_); }
  VtkMessages(const VtkMessages&) = delete;
  VtkMessages& operator=(const VtkMessages&) = delete;

  void Listen(vtkObject* object) {
    object->AddObserver(vtkCommand::ErrorEvent, callback_);
    object->AddObserver(vtkCommand::WarningEvent, callback_);
  }
  bool failed() const { return failed_; }
  std::string Said() const { return text_.empty() ? "" : " (VTK: " + text_ + ")"; }

 private:
  class Window final : public vtkOutputWindow {
   public:
    static Window* New();
    void DisplayText(const char* text) override { messages->Add(text); }
    VtkMessages* messages = nullptr;
  };

  static void Collect(vtkObject*, unsigned long, void* client, void* message) {
    static_cast<VtkMessages*>(client)->Add(static_cast<const char*>(message));
  }

  void Add(const char* message) {
    failed_ = true;
    if (!text_.empty()) text_ += "; ";
    std::string said = message ? message : "(no message)";
    while (!said.empty() && std::isspace(static_cast<unsigned char>(said.back()))) said.pop_back();
    text_ += said;
  }

  vtkNew<vtkCallbackCommand> callback_;
  vtkNew<Window> window_;
  vtkSmartPointer<vtkOutputWindow> previous_window_;
  std::string text_;
  bool failed_ = false;
};

vtkStandardNewMacro(VtkMessages::Window);

[[noreturn]] void Unreadable(const std::string& path, Format format, const std::string& problem) {
  throw Error(std::string("cannot read the ") + FormatName(format) + " surface mesh: " + problem, path,
              "export the surface again from its tool (ParaView, 3D Slicer, MeshLab, Blender) as " +
                  SurfaceMeshExtensions() + ", or check the extension names its format");
}

// VTK's STL reader reads a binary file cut short without a word. A binary
// STL is an 80-byte header, a triangle count n and 50 bytes per triangle; a
// file of another size is text (which VTK parses strictly) or broken.
void CheckBinaryStlSize(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char head[84];
  if (!in.read(head, sizeof head)) return;  // too short to be binary
  std::uint32_t count;
  std::memcpy(&count, head + 80, sizeof count);
  const std::uintmax_t size = std::filesystem::file_size(path), expected = 84 + 50 * std::uintmax_t{count};
  if (size == expected) return;
  const bool text = std::all_of(head, head + sizeof head, [](char c) {
    return std::isprint(static_cast<unsigned char>(c)) || std::isspace(static_cast<unsigned char>(c));
  });
  if (text) return;
  Unreadable(path, Format::kStl,
             "a binary STL of " + std::to_string(count) + " triangles has " + std::to_string(expected) +
                 " bytes, this file " + std::to_string(size) + " (cut short, or not an STL)");
}

// A reader of `format` on `path`, after the checks that VTK's own readers
// make without printing (so that a wrong file is named rather than parsed).
vtkSmartPointer<vtkAlgorithm> MakeReader(const std::string& path, Format format, VtkMessages* messages) {
  switch (format) {
    case Format::kStl: {
      CheckBinaryStlSize(path);
      auto reader = vtkSmartPointer<vtkSTLReader>::New();
      messages->Listen(reader);
      reader->SetFileName(path.c_str());
      reader->MergingOn();  // STL repeats each corner per facet: share them
      return reader;
    }
    case Format::kLegacyVtk: {
      auto reader = vtkSmartPointer<vtkPolyDataReader>::New();
      messages->Listen(reader);
      reader->SetFileName(path.c_str());
      if (!reader->IsFilePolyData()) {
        throw Error("the legacy VTK file holds no POLYDATA (an unstructured grid or an image is not a surface)" +
                        messages->Said(),
                    path,
                    "save the surface as polydata (ParaView: Extract Surface, then save as .vtk or .vtp)");
      }
      return reader;
    }
    case Format::kXmlPolyData: {
      auto reader = vtkSmartPointer<vtkXMLPolyDataReader>::New();
      messages->Listen(reader);
      if (!reader->CanReadFile(path.c_str())) Unreadable(path, format, "not a VTKFile of type PolyData");
      reader->SetFileName(path.c_str());
      return reader;
    }
    case Format::kObj:
    case Format::kPly:
      break;
  }
  DG_CHECK(false);  // OBJ and PLY have readers of their own
  return nullptr;
}

// Per-vertex attributes of `data` as Rows x n, or empty when absent or of another size.
template <int Rows>
Eigen::Matrix<double, Rows, Eigen::Dynamic> Attribute(vtkDataArray* data, vtkIdType num_points) {
  Eigen::Matrix<double, Rows, Eigen::Dynamic> values(Rows, 0);
  if (!data || data->GetNumberOfTuples() != num_points || data->GetNumberOfComponents() < Rows) return values;
  values.resize(Rows, num_points);
  for (vtkIdType i = 0; i < num_points; ++i) {
    for (int r = 0; r < Rows; ++r) values(r, i) = data->GetComponent(i, r);
  }
  return values;
}

// In the file's units.
SurfaceMesh ReadWithVtk(const std::string& path, Format format) {
  // The output window is global: one read at a time.
  static std::mutex one_read;
  std::lock_guard lock(one_read);
  VtkMessages messages;
  vtkSmartPointer<vtkAlgorithm> reader = MakeReader(path, format, &messages);
  messages.Listen(reader->GetExecutive());
  vtkNew<vtkTriangleFilter> triangles;
  messages.Listen(triangles);
  messages.Listen(triangles->GetExecutive());
  triangles->SetInputConnection(reader->GetOutputPort());
  triangles->PassVertsOff();
  triangles->PassLinesOff();
  triangles->Update();
  if (messages.failed()) Unreadable(path, format, "VTK's reader failed" + messages.Said());
  vtkPolyData* surface = triangles->GetOutput();
  const vtkIdType num_points = surface->GetNumberOfPoints();
  if (num_points == 0 || surface->GetNumberOfPolys() == 0) {
    Unreadable(path, format, "no triangle read" + messages.Said());
  }
  SurfaceMesh mesh;
  mesh.vertices_m.resize(3, num_points);
  for (vtkIdType i = 0; i < num_points; ++i) surface->GetPoint(i, mesh.vertices_m.col(i).data());
  mesh.triangles.resize(3, surface->GetNumberOfPolys());
  auto cells = vtk::TakeSmartPointer(surface->GetPolys()->NewIterator());
  Eigen::Index t = 0;
  for (cells->GoToFirstCell(); !cells->IsDoneWithTraversal(); cells->GoToNextCell(), ++t) {
    vtkIdType size;
    const vtkIdType* corners;
    cells->GetCurrentCell(size, corners);
    DG_CHECK(size == 3);  // the triangle filter's output
    for (int c = 0; c < 3; ++c) mesh.triangles(c, t) = static_cast<int>(corners[c]);
  }
  mesh.normals = Attribute<3>(surface->GetPointData()->GetNormals(), num_points);
  mesh.uvs = Attribute<2>(surface->GetPointData()->GetTCoords(), num_points);
  return mesh;
}

}  // namespace

bool IsSurfaceMeshFile(const std::string& path) { return FormatOfExtension().count(LowerExtension(path)) > 0; }

const std::string& SurfaceMeshExtensions() {
  static const std::string kExtensions = ".obj, .ply, .stl, .vtk or .vtp";
  return kExtensions;
}

SurfaceMesh ReadSurfaceMesh(const std::string& path, const SurfaceFileOptions& options) {
  DG_CHECK(options.metres_per_unit > 0);
  const auto format = FormatOfExtension().find(LowerExtension(path));
  if (format == FormatOfExtension().end()) {
    throw Error("unknown surface mesh format '" + LowerExtension(path) + "'", path,
                "give a surface mesh as " + SurfaceMeshExtensions() + " (the extension names the format)");
  }
  if (!std::ifstream(path)) throw Error("cannot open the surface mesh", path, "check the path");
  SurfaceMesh mesh = format->second == Format::kObj   ? ReadObj(path)
                     : format->second == Format::kPly ? ReadPly(path)
                                                      : ReadWithVtk(path, format->second);
  if (mesh.num_triangles() == 0) Unreadable(path, format->second, "no face");
  if (!mesh.vertices_m.allFinite()) Unreadable(path, format->second, "a vertex coordinate is not finite");
  mesh.vertices_m *= options.metres_per_unit;
  return mesh;
}

}  // namespace dg::io
