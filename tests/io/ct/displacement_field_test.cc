// The displacement field's file and its trilinear sampling, against an affine
// field (which trilinear interpolation reproduces exactly) on an oblique grid.
#include "io/ct/displacement_field.h"

#include <fstream>

#include <catch2/catch.hpp>

#include "tests/io/ct/ct_fixtures.h"
#include "tests/support/temporary_folder.h"

namespace dg::io {
namespace {

using Catch::Matchers::Contains;

// u(X) = A X + b, mm, X in metres.
Eigen::Vector3d Affine(const Eigen::Vector3d& X_m) {
  Eigen::Matrix3d A;
  A << 10, -20, 5,  //
      3, 40, -7,    //
      -11, 2, 30;
  return A * X_m + Eigen::Vector3d(0.5, -1.25, 2.0);
}

DisplacementField AffineField() {
  DisplacementField field = ZeroFieldOn(
      testing::PatternCt({6, 5, 4}, {1e-3, 1.5e-3, 2e-3}, {-0.01, 0.02, -0.005}, testing::ObliqueDirection()));
  for (int k = 0; k < 4; ++k) {
    for (int j = 0; j < 5; ++j) {
      for (int i = 0; i < 6; ++i) field.u_mm.col(field.Index(i, j, k)) = Affine(field.PointOf(i, j, k)).cast<float>();
    }
  }
  return field;
}

TEST_CASE("displacement field: written and read back, the same grid and vectors, compressed or not", "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_dvf");
  const DisplacementField field = AffineField();
  for (bool compress : {true, false}) {
    const std::string path = temporary.path() + (compress ? "/dvf.mha" : "/dvf_raw.mha");
    WriteDisplacementField(path, field, compress);
    const DisplacementField back = ReadDisplacementField(path);
    REQUIRE(back.size == field.size);
    REQUIRE((back.spacing_m - field.spacing_m).cwiseAbs().maxCoeff() < 1e-12);
    REQUIRE((back.origin_m - field.origin_m).cwiseAbs().maxCoeff() < 1e-12);
    REQUIRE((back.direction - field.direction).cwiseAbs().maxCoeff() < 1e-9);
    REQUIRE(back.u_mm == field.u_mm);
  }
  // MetaImage's header says what 3D Slicer and ITK read a displacement field by.
  std::ifstream header(temporary.File("dvf.mha"));
  std::string text((std::istreambuf_iterator<char>(header)), std::istreambuf_iterator<char>());
  text = text.substr(0, text.find("ElementDataFile"));
  REQUIRE_THAT(text, Contains("ElementNumberOfChannels = 3") && Contains("ElementType = MET_FLOAT") &&
                         Contains("CompressedData = True"));
}

TEST_CASE("displacement field: trilinear sampling reproduces an affine field anywhere inside the grid", "[unit]") {
  const DisplacementField field = AffineField();
  double worst = 0;
  for (double a : {0.0, 0.13, 0.5, 0.77, 1.0}) {
    const Eigen::Vector3d c(5 * a, 4 * (1 - a), 3 * a * a);  // voxel coordinates, corners included
    const Eigen::Vector3d X = field.origin_m + field.direction * field.spacing_m.cwiseProduct(c);
    worst = std::max(worst, (field.SampleMm(X) - Affine(X)).norm());
  }
  REQUIRE(worst < 1e-5);  // float storage of values up to a few mm
  const Eigen::Vector3d outside = field.PointOf(5, 4, 3) + field.direction * Eigen::Vector3d(1e-4, 0, 0);
  REQUIRE_THROWS_WITH(field.SampleMm(outside), Contains("outside the displacement field's grid"));
}

}  // namespace
}  // namespace dg::io
