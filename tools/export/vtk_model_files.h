#pragma once

#include <string>

#include <Eigen/Core>

namespace dg::tools {

// Models for 3D Slicer in VTK's own formats, written by VTK's writers.
// Coordinates are millimetres in the scan frame S, and each file names its
// frame LPS the way Slicer writes and reads it: "SPACE=LPS" in a legacy
// file's header line, a string array SPACE in an XML file's field data.
// Slicer then loads the model without asking for its frame; other VTK
// readers see plain coordinates. Binary data, so the doubles read back exactly.

// Writes a triangulated surface as legacy VTK polydata (.vtk, file version
// 4.2, which every Slicer and VTK release reads). title: the header line's
// first words (under 200 characters).
// @throws dg::Error naming the file when VTK cannot write it.
void WriteVtkPolyData(const std::string& path, const Eigen::Matrix3Xd& points_mm, const Eigen::Matrix3Xi& triangles,
                      const std::string& title);

// Writes a tetrahedral mesh as a VTK XML unstructured grid (.vtu).
// @throws dg::Error naming the file when VTK cannot write it.
void WriteVtuTetrahedra(const std::string& path, const Eigen::Matrix3Xd& points_mm,
                        const Eigen::Matrix<int, 4, Eigen::Dynamic>& tets);

}  // namespace dg::tools
