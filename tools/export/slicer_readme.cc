// README.txt of a Slicer export: written beside the files, read by whoever opens the folder.
#include <cstdio>
#include <sstream>

#include "tools/export/slicer_export.h"

namespace dg::tools {

std::string SlicerReadme(const SlicerExport& exported) {
  std::ostringstream text;
  text << "dynaguide export for 3D Slicer\n\n"
          "Units: millimetres throughout. Frame: the meshes and the CT are in the scan frame S, the\n"
          "CT's physical frame as ITK and Slicer read it (LPS; for a DICOM CT, the patient frame).\n"
          "Each model file says SPACE=LPS, so Slicer places it on the CT without asking.\n\nFiles:\n";
  for (const ExportedFile& file : exported.files) text << "  " << file.name << "\n      " << file.what << "\n";
  if (exported.ct_file.empty()) text << "  (no CT: the scene has no preoperative: {ct: ...})\n";

  text << "\nLoad in 3D Slicer (4.11 or later):\n"
          "  1. File > Add Data (or drag the folder's files onto Slicer's window), select\n"
          "     every file above but README.txt, OK. "
       << (exported.ct_file.empty() ? "" : exported.ct_file + " loads as a volume, ")
       << "the .vtk and .vtu\n"
          "     files as models, "
       << exported.transform_file
       << " as a linear transform named \"registration\".\n"
          "  2. The models lie on the CT in S: check a mesh against the CT in the slice views\n"
          "     (Models module > Display > Slice display > Visibility).\n"
          "  3. Apply the registration: in the Data module drag the CT and the models onto the\n"
          "     \"registration\" transform (or Transforms module > Apply transform). They move\n"
          "     into the left camera frame C, where the video's triangulated points lie.\n"
          "     Harden the transform (right-click > Harden transform) to save them in C.\n\n"
          "The transform: "
       << exported.transform_file
       << " is an ITK AffineTransform_double_3_3 holding T_S_C,\n"
          "the inverse of T_C_S, in millimetres: it maps camera points to scan points, ITK's\n"
          "resampling sense with C the fixed space and S the moving one. Slicer reads a transform\n"
          "file as \"from parent\", so the node's \"to parent\" is T_C_S, which carries S into C.\n"
          "Slicer shows coordinates as RAS and takes C, like the files, as LPS: a point at\n"
          "(x, y, z) mm in the camera frame shows at R = -x, A = -y, S = z.\n\n"
          "T_C_S (scan to left camera, mm), from "
       << exported.registration_source << ":\n";
  for (int r = 0; r < 4; ++r) {
    char row[128];
    std::snprintf(row, sizeof row, "  %12.6f %12.6f %12.6f %14.6f\n", exported.T_C_S_mm(r, 0), exported.T_C_S_mm(r, 1),
                  exported.T_C_S_mm(r, 2), exported.T_C_S_mm(r, 3));
    text << row;
  }
  return text.str();
}

}  // namespace dg::tools
