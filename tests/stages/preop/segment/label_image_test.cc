// The segmentation's label image reads back through ITK (as 3D Slicer reads
// it) with its voxels' labels and the grid's geometry, on a mirroring grid.
#include <cstdint>
#include <filesystem>
#include <string>

#include <Eigen/Dense>
#include <catch2/catch.hpp>
#include <itkImage.h>
#include <itkImageFileReader.h>

#include "io/ct/itk_factories.h"
#include "sim/error.h"
#include "stages/preop/segment/label_image_writer.h"
#include "stages/preop/segment/segmentation.h"

namespace dg::stages::preop {
namespace {

using Catch::Matchers::Contains;

// A segmentation on 12 x 10 x 8 voxels of 0.5 x 0.75 x 2 mm with a direction
// that swaps and flips axes: organ a box, mount its bottom layer, two
// internal structures inside the organ.
Segmentation Boxes() {
  io::CtImage grid;
  grid.size = Eigen::Vector3i(12, 10, 8);
  grid.spacing_m = Eigen::Vector3d(0.5e-3, 0.75e-3, 2e-3);
  grid.origin_m = Eigen::Vector3d(0.0125, -0.25, 0.5);
  grid.direction << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  Segmentation s;
  s.organ = VoxelMask::OnGridOf(grid);
  s.mount = VoxelMask::OnGridOf(grid);
  s.internal = {VoxelMask::OnGridOf(grid), VoxelMask::OnGridOf(grid)};
  for (int k = 0; k < 8; ++k)
    for (int j = 0; j < 10; ++j)
      for (int i = 0; i < 12; ++i) {
        const std::size_t v = s.organ.Index(i, j, k);
        s.mount.inside[v] = k == 0;
        s.organ.inside[v] = k >= 1 && i >= 2 && i < 10 && j >= 1 && j < 9;
        s.internal[0].inside[v] = k >= 2 && k < 5 && i >= 3 && i < 6 && j >= 2 && j < 8;
        s.internal[1].inside[v] = k >= 2 && k < 5 && i >= 7 && i < 9 && j >= 2 && j < 8;
      }
  return s;
}

std::uint8_t Expected(const Segmentation& s, std::size_t v) {
  if (s.internal[1].inside[v]) return 4;
  if (s.internal[0].inside[v]) return 3;
  if (s.organ.inside[v]) return 1;
  return s.mount.inside[v] ? 2 : 0;
}

TEST_CASE("preop segment: the label image reads back with its labels and geometry", "[unit]") {
  const Segmentation s = Boxes();
  io::RegisterItkImageIo();
  for (const char* extension : {".nii.gz", ".nrrd"}) {
    const std::string path = std::string(DG_BINARY_DIR) + "/preop_segment_labels" + extension;
    WriteLabelImage(s, path);
    auto reader = itk::ImageFileReader<itk::Image<std::uint8_t, 3>>::New();
    reader->SetFileName(path);
    reader->Update();
    const auto* image = reader->GetOutput();
    std::filesystem::remove(path);
    INFO(extension);
    for (int a = 0; a < 3; ++a) {
      CHECK(image->GetLargestPossibleRegion().GetSize()[a] == static_cast<unsigned>(s.organ.size[a]));
      CHECK(image->GetSpacing()[a] == Approx(1e3 * s.organ.spacing_m[a]).margin(1e-6));
      // NIfTI stores the origin as 32-bit floats: 250 mm to 1e-5 mm.
      CHECK(image->GetOrigin()[a] == Approx(1e3 * s.organ.origin_m[a]).margin(1e-4));
      for (int b = 0; b < 3; ++b) CHECK(image->GetDirection()(a, b) == Approx(s.organ.direction(a, b)).margin(1e-6));
    }
    const std::uint8_t* labels = image->GetBufferPointer();
    int wrong = 0;
    for (std::size_t v = 0; v < s.organ.num_voxels(); ++v) wrong += labels[v] != Expected(s, v);
    CHECK(wrong == 0);
  }
}

TEST_CASE("preop segment: a label image with an unknown extension is a named error", "[unit]") {
  REQUIRE_THROWS_WITH(WriteLabelImage(Boxes(), "labels.png"),
                      Contains("labels.png") && Contains(".nii.gz") && Contains("fix:"));
}

}  // namespace
}  // namespace dg::stages::preop
