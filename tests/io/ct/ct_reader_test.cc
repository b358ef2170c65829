// The CT reader against files others wrote: pydicom's CT_small.dcm (checked
// against what pydicom itself reads in it), images ITK writes in each format
// and pixel type, a NRRD header written by hand, and the project's MetaImage.
#include "io/ct/ct_reader.h"

#include <cmath>
#include <fstream>
#include <functional>

// The system's Eigen modules before ITK's headers: ITK's bundled Eigen (3.3,
// same guards) then uses them instead of compiling its own against ours.
#include <Eigen/Dense>
#include <catch2/catch.hpp>
#include <itkImage.h>
#include <itkImageFileWriter.h>

#include "io/ct/itk_factories.h"
#include "io/metaimage.h"
#include "tests/io/ct/ct_fixtures.h"
#include "tests/io/ct/pydicom_facts.h"
#include "tests/support/temporary_folder.h"

namespace dg::io {
namespace {

using Catch::Matchers::WithinAbs;

const std::string kPydicomFiles = "/usr/lib/python3/dist-packages/pydicom/data/test_files/";

// Writes through ITK an image of pixel type T whose voxel (i, j, k) holds value(i, j, k).
template <typename T, typename Value>
void WriteWithItk(const std::string& path, bool compress, const Eigen::Vector3i& n, const Eigen::Vector3d& spacing_mm,
                  const Eigen::Vector3d& origin_mm, const Eigen::Matrix3d& direction, Value value) {
  RegisterItkImageIo();
  using Image = itk::Image<T, 3>;
  auto image = Image::New();
  typename Image::SizeType size;
  typename Image::SpacingType spacing;
  typename Image::PointType origin;
  typename Image::DirectionType R;
  for (int a = 0; a < 3; ++a) {
    size[a] = n[a];
    spacing[a] = spacing_mm[a];
    origin[a] = origin_mm[a];
    for (int b = 0; b < 3; ++b) R(a, b) = direction(a, b);
  }
  image->SetRegions(typename Image::RegionType(size));
  image->SetSpacing(spacing);
  image->SetOrigin(origin);
  image->SetDirection(R);
  image->Allocate();
  for (int k = 0; k < n.z(); ++k) {
    for (int j = 0; j < n.y(); ++j) {
      for (int i = 0; i < n.x(); ++i) image->SetPixel({{i, j, k}}, static_cast<T>(value(i, j, k)));
    }
  }
  auto writer = itk::ImageFileWriter<Image>::New();
  writer->SetInput(image);
  writer->SetFileName(path);
  writer->SetUseCompression(compress);
  writer->Update();
}

void RequireFrame(const CtImage& ct, const Eigen::Vector3i& n, const Eigen::Vector3d& spacing_mm,
                  const Eigen::Vector3d& origin_mm, const Eigen::Matrix3d& direction) {
  REQUIRE(ct.size == n);
  REQUIRE((ct.spacing_m - 1e-3 * spacing_mm).cwiseAbs().maxCoeff() < 1e-9);
  REQUIRE((ct.origin_m - 1e-3 * origin_mm).cwiseAbs().maxCoeff() < 1e-9);
  REQUIRE((ct.direction - direction).cwiseAbs().maxCoeff() < 1e-6);
}

TEST_CASE("ct reader: pydicom's CT_small.dcm reads to the HU, spacing, position and orientation pydicom reports",
          "[integration]") {
  const std::string path = kPydicomFiles + "CT_small.dcm";
  const std::vector<testing::PydicomFile> truth = testing::ReadWithPydicom(path, /*pixels=*/true);
  REQUIRE(truth.size() == 1);
  const testing::PydicomFile& file = truth.front();
  const CtImage ct = ReadCtImage(path);

  const int rows = static_cast<int>(file.Number("Rows")), columns = static_cast<int>(file.Number("Columns"));
  REQUIRE(ct.size == Eigen::Vector3i(columns, rows, 1));
  // PixelSpacing is the spacing between rows (along j), then between columns (along i).
  REQUIRE_THAT(ct.spacing_m.x(), WithinAbs(1e-3 * file.Number("PixelSpacing", 1), 1e-12));
  REQUIRE_THAT(ct.spacing_m.y(), WithinAbs(1e-3 * file.Number("PixelSpacing", 0), 1e-12));
  for (int a = 0; a < 3; ++a) {
    REQUIRE_THAT(ct.origin_m[a], WithinAbs(1e-3 * file.Number("ImagePositionPatient", a), 1e-9));
    REQUIRE_THAT(ct.direction(a, 0), WithinAbs(file.Number("ImageOrientationPatient", a), 1e-9));
    REQUIRE_THAT(ct.direction(a, 1), WithinAbs(file.Number("ImageOrientationPatient", 3 + a), 1e-9));
  }
  REQUIRE((ct.direction.col(2) - ct.direction.col(0).cross(ct.direction.col(1))).norm() < 1e-9);
  REQUIRE(ct.series_uid == file.Text("SeriesInstanceUID"));

  // The stored pixels are positive; the rescale (intercept -1024) makes them HU.
  REQUIRE(file.Number("RescaleIntercept") == -1024);
  REQUIRE(file.hu.size() == ct.num_voxels());
  double max_difference = 0;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < columns; ++c) {
      max_difference = std::max(max_difference, std::abs(ct.at(c, r, 0) - file.hu[size_t(r) * columns + c]));
    }
  }
  REQUIRE(max_difference == 0);
  REQUIRE(ct.at(0, 0, 0) == -849);  // what pydicom printed when this test was written
}

TEST_CASE("ct reader: NIfTI, NRRD and MetaImage, compressed or not, of several pixel types, read to their voxels and frame",
          "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_formats");
  const Eigen::Vector3i n(7, 5, 4);
  const Eigen::Vector3d spacing(0.7, 0.8, 1.25), origin(-12.5, 30.25, -7.0);
  // Other orientations: ct_orientation_test.cc.
  const Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  auto hu = [](int i, int j, int k) { return -1000 + i + 10 * j + 100 * k; };
  auto label = [](int i, int j, int k) { return (i + 3 * j + 5 * k) % 7; };
  auto fraction = [](int i, int j, int k) { return 0.25 * i - 0.5 * j + 1.75 * k; };

  struct Case {
    std::string name;
    std::function<void(const std::string&)> write;
    std::function<double(int, int, int)> value;
  };
  const std::vector<Case> cases = {
      {"ct.nii.gz", [&](const std::string& p) { WriteWithItk<int16_t>(p, true, n, spacing, origin, R, hu); }, hu},
      {"ct.nii", [&](const std::string& p) { WriteWithItk<int32_t>(p, false, n, spacing, origin, R, hu); }, hu},
      {"labels.nrrd", [&](const std::string& p) { WriteWithItk<uint8_t>(p, true, n, spacing, origin, R, label); }, label},
      {"ct.mha", [&](const std::string& p) { WriteWithItk<float>(p, true, n, spacing, origin, R, fraction); }, fraction},
      {"ct.mhd", [&](const std::string& p) { WriteWithItk<double>(p, false, n, spacing, origin, R, fraction); }, fraction},
      {"ct_u16.mha", [&](const std::string& p) { WriteWithItk<uint16_t>(p, false, n, spacing, origin, R, label); }, label},
  };
  for (const Case& c : cases) {
    INFO(c.name);
    const std::string path = temporary.path() + "/" + c.name;
    c.write(path);
    // Labels and fractions are not HU: read as stored.
    const CtImage ct = ReadCtImage(path, {.intensity = c.name.rfind("ct.nii", 0) == 0 ? CtIntensity::kHu : CtIntensity::kNotHu});
    // NIfTI stores its frame as float quaternion and offsets: a few 1e-7 of rounding.
    REQUIRE(ct.size == n);
    REQUIRE((ct.spacing_m - 1e-3 * spacing).cwiseAbs().maxCoeff() < 1e-9);
    REQUIRE((ct.origin_m - 1e-3 * origin).cwiseAbs().maxCoeff() < 1e-8);
    REQUIRE((ct.direction - R).cwiseAbs().maxCoeff() < 1e-6);
    double max_difference = 0;
    for (int k = 0; k < n.z(); ++k) {
      for (int j = 0; j < n.y(); ++j) {
        for (int i = 0; i < n.x(); ++i) max_difference = std::max(max_difference, std::abs(ct.at(i, j, k) - c.value(i, j, k)));
      }
    }
    REQUIRE(max_difference == 0);
  }
}

TEST_CASE("ct reader: a NRRD header written by hand in LPS space gives its space directions and origin", "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_nrrd");
  {
    std::ofstream header(temporary.File("ct.nhdr"));
    header << "NRRD0004\ntype: short\ndimension: 3\nspace: left-posterior-superior\nsizes: 3 2 2\n"
              "space directions: (0,0.5,0) (-2,0,0) (0,0,3)\nspace origin: (10,20,30)\nkinds: domain domain domain\n"
              "endian: little\nencoding: raw\ndata file: ct.raw\n";
    std::ofstream raw(temporary.File("ct.raw"), std::ios::binary);
    for (int16_t v = 0; v < 12; ++v) raw.write(reinterpret_cast<const char*>(&v), sizeof v);
  }
  // The file's voxel axes are +y, -x and +z of S ("PRS"): the reader moves them onto S's axes, so its
  // voxel (i, j, k) is the file's (j, 1 - i, k), and the origin the file's voxel (0, 1, 0), at
  // (10, 20, 30) + 2 (-1, 0, 0) mm.
  const CtImage ct = ReadCtImage(temporary.File("ct.nhdr"), {.intensity = CtIntensity::kNotHu});
  REQUIRE(ct.reoriented_from == "PRS");
  RequireFrame(ct, {2, 3, 2}, {2, 0.5, 3}, {8, 20, 30}, Eigen::Matrix3d::Identity());
  for (int k = 0; k < 2; ++k) {
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 2; ++i) REQUIRE(ct.at(i, j, k) == j + 3 * (1 - i) + 6 * k);
    }
  }
  // The file's voxel (1, 1, 1), at origin + 0.5 (0,1,0) + 2 (-1,0,0) + 3 (0,0,1) mm, is the reader's (0, 1, 1).
  REQUIRE((ct.PointOf(0, 1, 1) - 1e-3 * Eigen::Vector3d(8, 20.5, 33)).norm() < 1e-12);
  REQUIRE(ct.at(0, 1, 1) == 1 + 3 * 1 + 6 * 1);
}

TEST_CASE("ct reader: the project's own MetaImage reads through ITK to the voxels and frame its reader gives", "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_metaimage");
  VolumeI16 volume;
  volume.size = {6, 4, 3};
  volume.spacing_m = {1e-3, 1.5e-3, 2e-3};
  volume.origin_m = {-0.031, 0.002, -0.005};
  for (size_t v = 0; v < volume.num_voxels(); ++v) volume.values.push_back(static_cast<int16_t>(-1000 + 37 * v));
  WriteMetaImage(temporary.File("ct.mhd"), volume);
  const VolumeI16 own = ReadMetaImage<int16_t>(temporary.File("ct.mhd"));
  const CtImage ct = ReadCtImage(temporary.File("ct.mhd"), {.intensity = CtIntensity::kNotHu});
  RequireFrame(ct, own.size, 1e3 * own.spacing_m, 1e3 * own.origin_m, Eigen::Matrix3d::Identity());
  for (size_t v = 0; v < own.num_voxels(); ++v) REQUIRE(ct.values[v] == own.values[v]);
}

}  // namespace
}  // namespace dg::io
