// The DICOM series writer: what it writes reads back through the reader to the
// same voxels and frame, pydicom reads its tags and pixels as written, and the
// same input writes the same bytes.
#include "io/ct/dicom_writer.h"

#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <set>

#include <catch2/catch.hpp>

#include "io/ct/axis_aligned.h"
#include "io/ct/ct_reader.h"
#include "tests/io/ct/ct_fixtures.h"
#include "tests/io/ct/pydicom_facts.h"
#include "tests/support/temporary_folder.h"

namespace dg::io {
namespace {

namespace fs = std::filesystem;
using Catch::Matchers::WithinAbs;

std::string Bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST_CASE("dicom writer: a CT written as a series reads back to the same voxels and frame, oblique or not", "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_dicom_roundtrip");
  for (const Eigen::Matrix3d& R : std::vector<Eigen::Matrix3d>{Eigen::Matrix3d::Identity(), testing::ObliqueDirection()}) {
    const CtImage ct = testing::PatternCt({6, 5, 4}, {0.7e-3, 0.9e-3, 1.25e-3}, {-0.0125, 0.03025, -0.007}, R);
    const std::string folder = temporary.File("series");
    fs::remove_all(folder);
    WriteDicomSeries(ct, folder, testing::PhaseInfo("roundtrip", 1, 1));
    const CtImage back = ReadCtImage(folder);
    // The reader puts an oblique CT on S's axes: the written frame must resample as the original does.
    const CtImage expected = OnAxisAlignedGrid(ct, Interpolation::kLinear, -1024);
    REQUIRE(back.size == expected.size);
    // Positions and spacings are written as decimal text of 10 significant digits.
    REQUIRE((back.spacing_m - expected.spacing_m).cwiseAbs().maxCoeff() < 1e-12);
    REQUIRE((back.origin_m - expected.origin_m).cwiseAbs().maxCoeff() < 1e-11);
    REQUIRE(back.direction == Eigen::Matrix3d::Identity());
    REQUIRE(back.reoriented_from == expected.reoriented_from);
    double max_difference = 0;
    for (size_t v = 0; v < back.num_voxels(); ++v) {
      max_difference = std::max<double>(max_difference, std::abs(back.values[v] - expected.values[v]));
    }
    // Identity: the stored int16 exactly; oblique: the same interpolation of a frame rounded to 1e-10.
    REQUIRE(max_difference < 1e-3);
    if (R.isIdentity()) REQUIRE(back.values == ct.values);
    REQUIRE(back.series_uid == DeterministicUid("roundtrip phase 1"));
  }
}

TEST_CASE("dicom writer: pydicom reads the series' modality, UIDs, positions, rescale, phase tags and HU", "[integration]") {
  const testing::TemporaryFolder temporary("dg_ct_dicom_pydicom");
  const CtImage ct = testing::PatternCt({5, 4, 3}, {0.8e-3, 0.6e-3, 1.5e-3}, {-0.01, 0.02, -0.03},
                                        testing::ObliqueDirection());
  DicomSeriesInfo info = testing::PhaseInfo("pydicom", 4, 10);
  info.cycle_fraction = 0.3;
  info.trigger_time_ms = 200;
  info.heart_rate_bpm = 90;
  WriteDicomSeries(ct, temporary.path(), info);
  const std::vector<testing::PydicomFile> files = testing::ReadWithPydicom(temporary.path(), /*pixels=*/true);
  REQUIRE(files.size() == 3);
  std::set<std::string> sop_uids;
  for (int k = 0; k < 3; ++k) {
    const testing::PydicomFile& file = files[k];
    INFO(file.name);
    REQUIRE(file.Text("Modality") == "CT");
    REQUIRE(file.Text("SOPClassUID") == "1.2.840.10008.5.1.4.1.1.2");
    REQUIRE(file.Text("StudyInstanceUID") == info.study_uid);
    REQUIRE(file.Text("SeriesInstanceUID") == info.series_uid);
    REQUIRE(file.Text("FrameOfReferenceUID") == files[0].Text("FrameOfReferenceUID"));
    REQUIRE(std::regex_match(file.Text("SOPInstanceUID"), std::regex(R"([0-9]+(\.[0-9]+)*)")));
    sop_uids.insert(file.Text("SOPInstanceUID"));
    REQUIRE(file.Number("InstanceNumber") == k + 1);
    for (int a = 0; a < 3; ++a) {
      REQUIRE_THAT(file.Number("ImagePositionPatient", a), WithinAbs(1e3 * ct.PointOf(0, 0, k)[a], 1e-8));
      REQUIRE_THAT(file.Number("ImageOrientationPatient", a), WithinAbs(ct.direction(a, 0), 1e-9));
      REQUIRE_THAT(file.Number("ImageOrientationPatient", 3 + a), WithinAbs(ct.direction(a, 1), 1e-9));
    }
    REQUIRE_THAT(file.Number("PixelSpacing", 0), WithinAbs(0.6, 1e-9));  // between rows: along j
    REQUIRE_THAT(file.Number("PixelSpacing", 1), WithinAbs(0.8, 1e-9));
    REQUIRE_THAT(file.Number("SliceThickness"), WithinAbs(1.5, 1e-9));
    REQUIRE(file.Number("Rows") == 4);
    REQUIRE(file.Number("Columns") == 5);
    REQUIRE(file.Number("RescaleSlope") == 1);
    REQUIRE(file.Number("RescaleIntercept") == -1024);
    REQUIRE(file.Number("TemporalPositionIdentifier") == 4);
    REQUIRE(file.Number("NumberOfTemporalPositions") == 10);
    REQUIRE_THAT(file.Number("NominalPercentageOfCardiacPhase"), WithinAbs(30, 1e-4));
    REQUIRE_THAT(file.Number("TriggerTime"), WithinAbs(200, 1e-9));
    REQUIRE(file.Number("HeartRate") == 90);
    REQUIRE(file.Text("PatientID") == "TEST");
    // Row r, column c of slice k is voxel (c, r, k).
    REQUIRE(file.hu.size() == 20);
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 5; ++c) REQUIRE(file.hu[r * 5 + c] == ct.at(c, r, k));
    }
  }
  REQUIRE(sop_uids.size() == 3);
}

TEST_CASE("dicom writer: the same CT and information write the same bytes", "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_dicom_bytes");
  const CtImage ct = testing::SmallCt();
  WriteDicomSeries(ct, temporary.File("a"), testing::PhaseInfo("bytes", 1, 2));
  WriteDicomSeries(ct, temporary.File("b"), testing::PhaseInfo("bytes", 1, 2));
  int files = 0;
  for (const auto& entry : fs::directory_iterator(temporary.File("a"))) {
    INFO(entry.path().filename());
    REQUIRE(Bytes(entry.path().string()) == Bytes(temporary.path() + "/b/" + entry.path().filename().string()));
    ++files;
  }
  REQUIRE(files == ct.size.z());
}

TEST_CASE("dicom writer: deterministic UIDs are valid, stable and distinct; bad information is refused", "[unit]") {
  const std::string uid = DeterministicUid("a phantom");
  REQUIRE(uid == DeterministicUid("a phantom"));
  REQUIRE(uid != DeterministicUid("a phantom."));
  REQUIRE(std::regex_match(uid, std::regex(R"(2\.25\.[1-9][0-9]*)")));
  REQUIRE(uid.size() <= 44);

  DicomSeriesInfo info = testing::PhaseInfo("refused", 1, 1);
  REQUIRE(info.Validate().empty());
  info.series_uid = "1.2.03";
  REQUIRE_THAT(info.Validate(), Catch::Matchers::Contains("series UID"));
  info = testing::PhaseInfo("refused", 3, 2);
  REQUIRE_THAT(info.Validate(), Catch::Matchers::Contains("temporal position"));
  const testing::TemporaryFolder temporary("dg_ct_dicom_refused");
  REQUIRE_THROWS_WITH(
      WriteDicomSeries(testing::SmallCt(), temporary.path(), info),
      Catch::Matchers::Contains("invalid DICOM series information") && Catch::Matchers::Contains("fix:"));
}

}  // namespace
}  // namespace dg::io
