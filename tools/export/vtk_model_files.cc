#include "tools/export/vtk_model_files.h"

#include <vtkCellArray.h>
#include <vtkCellType.h>
#include <vtkFieldData.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataWriter.h>
#include <vtkStringArray.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include "sim/error.h"

namespace dg::tools {
namespace {

// The tag Slicer reads a model file's frame from (NRRD's key, which Slicer follows).
constexpr const char* kSpaceTag = "SPACE";
constexpr const char* kSpace = "LPS";

vtkNew<vtkPoints> Points(const Eigen::Matrix3Xd& points_mm) {
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(points_mm.cols());
  for (Eigen::Index i = 0; i < points_mm.cols(); ++i) {
    points->SetPoint(i, points_mm(0, i), points_mm(1, i), points_mm(2, i));
  }
  return points;
}

void WriteFailed(const std::string& path) {
  throw Error("VTK could not write the model file", path,
              "check that the output folder is writable and its file system has free space");
}

}  // namespace

void WriteVtkPolyData(const std::string& path, const Eigen::Matrix3Xd& points_mm, const Eigen::Matrix3Xi& triangles,
                      const std::string& title) {
  vtkNew<vtkCellArray> polys;
  for (Eigen::Index t = 0; t < triangles.cols(); ++t) {
    const vtkIdType corners[3] = {triangles(0, t), triangles(1, t), triangles(2, t)};
    polys->InsertNextCell(3, corners);
  }
  vtkNew<vtkPolyData> surface;
  surface->SetPoints(Points(points_mm));
  surface->SetPolys(polys);

  vtkNew<vtkPolyDataWriter> writer;
  writer->SetFileName(path.c_str());
  writer->SetInputData(surface);
  // VTK 9 writes 5.1 by default, which readers built on VTK 8 (Slicer 4.x among them) and many other tools refuse.
  writer->SetFileVersion(vtkDataWriter::VTK_LEGACY_READER_VERSION_4_2);
  writer->SetFileTypeToBinary();
  writer->SetHeader((title + ", millimetres. " + kSpaceTag + "=" + kSpace).c_str());
  if (writer->Write() != 1) WriteFailed(path);
}

void WriteVtuTetrahedra(const std::string& path, const Eigen::Matrix3Xd& points_mm,
                        const Eigen::Matrix<int, 4, Eigen::Dynamic>& tets) {
  vtkNew<vtkUnstructuredGrid> grid;
  grid->SetPoints(Points(points_mm));
  grid->Allocate(tets.cols());
  for (Eigen::Index e = 0; e < tets.cols(); ++e) {
    const vtkIdType corners[4] = {tets(0, e), tets(1, e), tets(2, e), tets(3, e)};
    grid->InsertNextCell(VTK_TETRA, 4, corners);
  }
  vtkNew<vtkStringArray> space;
  space->SetName(kSpaceTag);
  space->InsertNextValue(kSpace);
  grid->GetFieldData()->AddArray(space);

  vtkNew<vtkXMLUnstructuredGridWriter> writer;
  writer->SetFileName(path.c_str());
  writer->SetInputData(grid);
  writer->SetDataModeToAppended();
  writer->EncodeAppendedDataOff();  // raw binary: exact doubles, no base64
  if (writer->Write() != 1) WriteFailed(path);
}

}  // namespace dg::tools
