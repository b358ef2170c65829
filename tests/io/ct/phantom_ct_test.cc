// The phantom's 4D CT as DICOM and as MetaImage, and its truth displacement
// fields, on the tiny phantom: both formats read to the same voxels and frame,
// pydicom reads the DICOM as written, and the fields agree with the exact node
// displacements of scan.h5.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <set>

#include <catch2/catch.hpp>

#include "io/ct/ct_reader.h"
#include "io/ct/displacement_field.h"
#include "io/gmsh_reader.h"
#include "io/h5_file.h"
#include "io/metaimage.h"
#include "tests/io/ct/ct_fixtures.h"
#include "tests/io/ct/pydicom_facts.h"
#include "tests/support/temporary_folder.h"
#include "tests/support/tiny_phantom.h"
#include "tools/phantom/phantom_spec.h"
#include "tools/phantom/scene_file.h"

namespace dg::io {
namespace {

using Catch::Matchers::Contains;
using Catch::Matchers::WithinAbs;

const int kPhases = tools::phantom::PresetSpec("tiny").phases;
// About twice the worst error measured (see the test).
constexpr double kDvfNodeErrorBound_mm = 0.003;  // measured 0.0014 mm

std::string PhasePath(const char* pattern, int k) {
  char name[64];
  std::snprintf(name, sizeof name, pattern, k);
  return testing::TinyPhantomDir() + name;
}

std::vector<std::string> PhasePaths(const char* pattern) {
  std::vector<std::string> paths;
  for (int k = 0; k < kPhases; ++k) paths.push_back(PhasePath(pattern, k));
  return paths;
}

TEST_CASE("phantom ct: its DICOM series and MetaImages read to the same voxels and frame, every phase",
          "[integration]") {
  const std::vector<CtImage> mhd = ReadCtPhases(PhasePaths("/ct/phase_%02d.mhd"), {});
  const std::vector<CtImage> dicom = ReadCtPhases(PhasePaths("/ct/dicom/phase_%02d"), {});
  REQUIRE(mhd.size() == size_t(kPhases));
  REQUIRE(dicom.size() == size_t(kPhases));
  const VolumeI16 own = ReadMetaImage<int16_t>(PhasePath("/ct/phase_%02d.mhd", 0));
  for (int k = 0; k < kPhases; ++k) {
    INFO("phase " << k);
    REQUIRE(dicom[k].size == own.size);
    REQUIRE(mhd[k].size == own.size);
    REQUIRE((dicom[k].spacing_m - own.spacing_m).cwiseAbs().maxCoeff() < 1e-12);
    // DICOM writes positions as decimal text of 10 significant digits.
    REQUIRE((dicom[k].origin_m - own.origin_m).cwiseAbs().maxCoeff() < 1e-10);
    REQUIRE((mhd[k].origin_m - own.origin_m).cwiseAbs().maxCoeff() < 1e-12);
    REQUIRE(dicom[k].direction == Eigen::Matrix3d::Identity());
    REQUIRE(dicom[k].values == mhd[k].values);
    REQUIRE_THAT(dicom[k].cycle_fraction, WithinAbs(double(k) / kPhases, 1e-6));
  }
  // The folder of the phases' folders, ordered by their phase tags.
  const std::vector<CtImage> by_tags = ReadCtPhases({testing::TinyPhantomDir() + "/ct/dicom"}, {});
  REQUIRE(by_tags.size() == size_t(kPhases));
  for (int k = 0; k < kPhases; ++k) REQUIRE(by_tags[k].values == dicom[k].values);
  // The phases differ (the heart moves), so equal voxels are not a degenerate match.
  REQUIRE(dicom[0].values != dicom[kPhases / 2].values);
}

TEST_CASE("phantom ct: pydicom reads its DICOM as one study of a CT series per phase on the MetaImage's grid",
          "[integration]") {
  const VolumeI16 grid = ReadMetaImage<int16_t>(PhasePath("/ct/phase_%02d.mhd", 0));
  std::set<std::string> series_uids, study_uids, frame_uids, sop_uids;
  for (int k = 0; k < kPhases; ++k) {
    INFO("phase " << k);
    const bool pixels = k == 3;
    const std::vector<testing::PydicomFile> files = testing::ReadWithPydicom(PhasePath("/ct/dicom/phase_%02d", k), pixels);
    REQUIRE(files.size() == size_t(grid.size.z()));
    std::set<std::string> series_of_phase;
    for (int s = 0; s < grid.size.z(); ++s) {
      const testing::PydicomFile& file = files[s];
      INFO(file.name);
      REQUIRE(file.Text("Modality") == "CT");
      series_of_phase.insert(file.Text("SeriesInstanceUID"));
      study_uids.insert(file.Text("StudyInstanceUID"));
      frame_uids.insert(file.Text("FrameOfReferenceUID"));
      sop_uids.insert(file.Text("SOPInstanceUID"));
      REQUIRE(file.Number("TemporalPositionIdentifier") == k + 1);
      REQUIRE(file.Number("NumberOfTemporalPositions") == kPhases);
      REQUIRE_THAT(file.Number("NominalPercentageOfCardiacPhase"), WithinAbs(100.0 * k / kPhases, 1e-4));
      for (int a = 0; a < 3; ++a) {
        const double expected_mm = 1e3 * (grid.origin_m[a] + (a == 2 ? s * grid.spacing_m.z() : 0.0));
        REQUIRE_THAT(file.Number("ImagePositionPatient", a), WithinAbs(expected_mm, 1e-7));
      }
      REQUIRE_THAT(file.Number("PixelSpacing", 0), WithinAbs(1e3 * grid.spacing_m.y(), 1e-9));
      REQUIRE_THAT(file.Number("SliceThickness"), WithinAbs(1e3 * grid.spacing_m.z(), 1e-9));
      if (pixels) {
        const VolumeI16 phase = ReadMetaImage<int16_t>(PhasePath("/ct/phase_%02d.mhd", k));
        REQUIRE(file.hu.size() == size_t(grid.size.x() * grid.size.y()));
        for (int j = 0; j < grid.size.y(); ++j) {
          for (int i = 0; i < grid.size.x(); ++i) REQUIRE(file.hu[j * grid.size.x() + i] == phase.at(i, j, s));
        }
      }
    }
    REQUIRE(series_of_phase.size() == 1);
    series_uids.insert(*series_of_phase.begin());
  }
  REQUIRE(series_uids.size() == size_t(kPhases));
  REQUIRE(study_uids.size() == 1);
  REQUIRE(frame_uids.size() == 1);
  REQUIRE(sop_uids.size() == size_t(kPhases * grid.size.z()));
}

TEST_CASE("phantom ct: the truth displacement fields sampled at the mesh nodes give scan.h5's node displacements",
          "[integration]") {
  const sim::TetMesh mesh = ReadGmsh(testing::TinyPhantomDir() + "/mesh.msh");
  H5Shape shape;
  const std::vector<double> truth =
      H5Reader(testing::TinyPhantomDir() + "/scan.h5").Read<double>("/phases/node_displacement_m", &shape);
  REQUIRE(shape == H5Shape{size_t(kPhases), size_t(mesh.num_nodes()), 3});
  const VolumeI16 grid = ReadMetaImage<int16_t>(PhasePath("/ct/phase_%02d.mhd", 0));
  double worst_mm = 0, largest_mm = 0;
  for (int k = 0; k < kPhases; ++k) {
    const DisplacementField field = ReadDisplacementField(PhasePath("/truth/dvf_phase_%02d.mha", k));
    REQUIRE(field.size == grid.size);
    REQUIRE((field.origin_m - grid.origin_m).cwiseAbs().maxCoeff() < 1e-12);
    REQUIRE((field.spacing_m - grid.spacing_m).cwiseAbs().maxCoeff() < 1e-12);
    if (k == 0) REQUIRE(field.u_mm.cwiseAbs().maxCoeff() == 0);  // phase 0 is the reference configuration
    for (int a = 0; a < mesh.num_nodes(); ++a) {
      const Eigen::Vector3d expected_mm = 1e3 * Eigen::Vector3d::Map(&truth[(size_t(k) * mesh.num_nodes() + a) * 3]);
      worst_mm = std::max(worst_mm, (field.SampleMm(mesh.X_m.col(a)) - expected_mm).norm());
      largest_mm = std::max(largest_mm, expected_mm.norm());
    }
  }
  INFO("largest node displacement " << largest_mm << " mm, worst interpolation error " << worst_mm << " mm");
  REQUIRE(largest_mm > 2);  // the motion is not trivially small
  // Trilinear interpolation of the smooth motion on the tiny phantom's 1.5 mm grid.
  REQUIRE(worst_mm < kDvfNodeErrorBound_mm);
}

TEST_CASE("phantom: scene.yaml names the MetaImages when they are written, and says where the DICOM is", "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_scene_file");
  for (const std::string format : {"mhd", "dicom", "both"}) {
    tools::phantom::PhantomSpec spec = tools::phantom::PresetSpec("tiny");
    spec.ct_format = format;
    REQUIRE(spec.Validate().empty());
    tools::phantom::WriteSceneFile(temporary.File("scene.yaml"), spec, 30, 0.666);
    std::ifstream in(temporary.File("scene.yaml"));
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    INFO(format << ":\n" << text);
    REQUIRE((text.find("  ct: ct/phase_%02d.mhd") != std::string::npos) == (format != "dicom"));
    REQUIRE((text.find("ct/dicom/phase_NN/") != std::string::npos) == (format != "mhd"));
  }
  tools::phantom::PhantomSpec spec = tools::phantom::PresetSpec("tiny");
  spec.ct_format = "png";
  REQUIRE_THAT(spec.Validate(), Contains("--ct-format"));
}

}  // namespace
}  // namespace dg::io
