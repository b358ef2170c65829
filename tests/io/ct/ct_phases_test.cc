// Reading a 4D CT's phases from each layout (one folder of every series, a
// folder per phase, a file per phase, series chosen by UID), and each kind of
// bad input refused with its own error naming what, where and the fix.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <fstream>
#include <iterator>

#include <catch2/catch.hpp>

#include "io/ct/ct_reader.h"
#include "io/ct/dicom_writer.h"
#include "io/metaimage.h"
#include "sim/error.h"
#include "tests/io/ct/ct_fixtures.h"
#include "tests/support/temporary_folder.h"

namespace dg::io {
namespace {

namespace fs = std::filesystem;
using Catch::Matchers::Contains;
using Catch::Matchers::WithinAbs;

const std::string kPydicomFiles = "/usr/lib/python3/dist-packages/pydicom/data/test_files/";

// Phases 1..count (skipping `skip`) written into `folder`/phase_N, phase p's
// voxels offset by p HU, with percentage tags.
std::vector<std::string> WritePhases(const std::string& folder, int count, int skip = 0) {
  std::vector<std::string> folders;
  for (int p = 1; p <= count; ++p) {
    if (p == skip) continue;
    DicomSeriesInfo info = testing::PhaseInfo(folder, p, count);
    info.cycle_fraction = double(p - 1) / count;
    folders.push_back(folder + "/phase_" + std::to_string(p));
    WriteDicomSeries(testing::SmallCt(p), folders.back(), info);
  }
  return folders;
}

// Every file of the folders moved into one folder, under names that do not sort in phase order.
void Merge(const std::vector<std::string>& folders, const std::string& into) {
  fs::create_directories(into);
  for (size_t f = 0; f < folders.size(); ++f) {
    for (const auto& entry : fs::directory_iterator(folders[f])) {
      fs::rename(entry.path(), fs::path(into) / (std::to_string(97 - 13 * f) + "_" + entry.path().filename().string()));
    }
  }
}

void RequirePhaseOffsets(const std::vector<CtImage>& phases, const std::vector<int>& offsets) {
  REQUIRE(phases.size() == offsets.size());
  for (size_t p = 0; p < phases.size(); ++p) REQUIRE(phases[p].values == testing::SmallCt(offsets[p]).values);
}

TEST_CASE("ct phases: one folder of every phase's series is ordered by the phase tags, with their cycle fractions",
          "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_phases_one_folder");
  Merge(WritePhases(temporary.File("separate"), 4), temporary.File("all"));
  int calls = 0;
  CtReadOptions options;
  options.progress = [&](const CtImage&, int index, int count) {
    REQUIRE(index == calls++);
    REQUIRE(count == 4);
  };
  const std::vector<CtImage> phases = ReadCtPhases({temporary.File("all")}, options);
  REQUIRE(calls == 4);
  RequirePhaseOffsets(phases, {1, 2, 3, 4});
  for (int p = 0; p < 4; ++p) REQUIRE_THAT(phases[p].cycle_fraction, WithinAbs(0.25 * p, 1e-6));
  REQUIRE(phases[2].series_uid == DeterministicUid(temporary.path() + "/separate phase 3"));
}

TEST_CASE("ct phases: folders and files are read in the order given; series UIDs choose and order series", "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_phases_given");
  const std::vector<std::string> folders = WritePhases(temporary.path(), 3);
  RequirePhaseOffsets(ReadCtPhases(folders, {}), {1, 2, 3});

  std::vector<std::string> files;
  for (int p = 0; p < 3; ++p) {
    VolumeI16 volume;
    const CtImage ct = testing::SmallCt(10 * p);
    volume.size = ct.size;
    volume.spacing_m = ct.spacing_m;
    volume.origin_m = ct.origin_m;
    volume.values.assign(ct.values.begin(), ct.values.end());
    files.push_back(temporary.path() + "/phase_" + std::to_string(p) + ".mhd");
    WriteMetaImage(files.back(), volume);
  }
  const std::vector<CtImage> from_files = ReadCtPhases(files, {});
  RequirePhaseOffsets(from_files, {0, 10, 20});
  REQUIRE(std::isnan(from_files[1].cycle_fraction));

  Merge({folders[0], folders[2]}, temporary.File("two"));
  CtReadOptions options;
  options.series_uids = {DeterministicUid(temporary.path() + " phase 1"),
                         DeterministicUid(temporary.path() + " phase 3")};
  RequirePhaseOffsets(ReadCtPhases({temporary.File("two")}, options), {1, 3});
  options.series_uids = {"1.2.3.4"};
  REQUIRE_THROWS_WITH(ReadCtPhases({temporary.File("two")}, options),
                      Contains("series UID 1.2.3.4 is in none of the inputs") &&
                          Contains(DeterministicUid(temporary.path() + " phase 3")) && Contains("fix:"));
}

TEST_CASE("ct phases: a missing phase is an error that names it", "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_phases_missing");
  Merge(WritePhases(temporary.File("separate"), 10, /*skip=*/7), temporary.File("all"));
  REQUIRE_THROWS_WITH(ReadCtPhases({temporary.File("all")}, {}), Contains("a phase is missing") && Contains("60%") &&
                                                                     Contains(temporary.File("all")) &&
                                                                     Contains("fix:"));
}

TEST_CASE("ct phases: a folder of several series with nothing to order them lists their UIDs and descriptions",
          "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_phases_mixed");
  std::vector<std::string> folders;
  for (const char* name : {"chest", "abdomen"}) {
    DicomSeriesInfo info;
    info.study_uid = DeterministicUid("mixed");
    info.series_uid = DeterministicUid(name);
    info.series_description = name;
    folders.push_back(temporary.path() + "/" + name);
    WriteDicomSeries(testing::SmallCt(), folders.back(), info);
  }
  Merge(folders, temporary.File("mixed"));
  for (const auto& read : std::vector<std::function<void()>>{[&] { ReadCtPhases({temporary.File("mixed")}, {}); },
                                                             [&] { ReadCtImage(temporary.File("mixed")); }}) {
    REQUIRE_THROWS_WITH(read(), Contains("holds 2") && Contains(DeterministicUid("chest")) && Contains("'chest'") &&
                                    Contains(DeterministicUid("abdomen")) && Contains("'abdomen'") &&
                                    Contains("select the") && Contains("fix:"));
  }
}

// The Modality element (0008,0060) of a file, "CT", made "MR".
void PatchModalityToMr(const std::string& file) {
  std::string bytes;
  {
    std::ifstream in(file, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const size_t tag = bytes.find(std::string("\x08\x00\x60\x00", 4));
  REQUIRE(tag != std::string::npos);
  const size_t value = bytes.find("CT", tag);
  REQUIRE(value - tag <= 8);  // after the tag, a VR and a length (explicit) or a length (implicit)
  bytes.replace(value, 2, "MR");
  std::ofstream(file, std::ios::binary) << bytes;
}

// Sets (KEYWORD=VALUE) or removes (KEYWORD=) tags in every file of a folder with pydicom.
void SetTagsWithPydicom(const std::string& folder, const std::string& changes) {
  const std::string command =
      "/usr/bin/python3 " DG_SOURCE_DIR "/tests/io/ct/set_dicom_tags.py '" + folder + "' " + changes + " 2>&1";
  INFO(command);
  REQUIRE(std::system(command.c_str()) == 0);
}

TEST_CASE("ct phases: a respiratory 4D CT is ordered by the respiratory tags pydicom writes", "[integration]") {
  const testing::TemporaryFolder temporary("dg_ct_phases_respiratory");
  // Phase p written with temporal position p; pydicom gives it the breathing phase 75, 50, 25, 0%
  // (NominalPercentageOfRespiratoryPhase, which comes first), so the cycle runs 4, 3, 2, 1.
  std::vector<std::string> folders;
  for (int p = 1; p <= 4; ++p) {
    folders.push_back(temporary.File("phase_" + std::to_string(p)));
    WriteDicomSeries(testing::SmallCt(p), folders.back(), testing::PhaseInfo(temporary.path(), p, 4));
    SetTagsWithPydicom(folders.back(), "NominalPercentageOfRespiratoryPhase=" + std::to_string(100 - 25 * p));
  }
  std::vector<CtImage> phases = ReadCtPhases({temporary.path()}, {});
  RequirePhaseOffsets(phases, {4, 3, 2, 1});
  REQUIRE_THAT(phases[1].cycle_fraction, WithinAbs(0.25, 1e-6));
  // Without it and the temporal position: the delay after the respiratory trigger, over the breath's
  // interval (4 s), gives the order and the fractions.
  for (int p = 1; p <= 4; ++p) {
    SetTagsWithPydicom(folders[p - 1], "NominalPercentageOfRespiratoryPhase= TemporalPositionIdentifier= "
                                       "NominalRespiratoryTriggerDelayTime=" + std::to_string(1000 * (4 - p)) +
                                           " RespiratoryIntervalTime=4000");
  }
  phases = ReadCtPhases({temporary.path()}, {});
  RequirePhaseOffsets(phases, {4, 3, 2, 1});
  REQUIRE_THAT(phases[3].cycle_fraction, WithinAbs(0.75, 1e-6));
}

TEST_CASE("ct phases: a modality other than CT is refused where a CT is expected, read as a label map", "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_phases_modality");
  const std::vector<std::string> folders = WritePhases(temporary.path(), 2);
  for (const auto& entry : fs::directory_iterator(folders[1])) PatchModalityToMr(entry.path().string());
  REQUIRE_THROWS_WITH(ReadCtPhases(folders, {}), Contains("modality is 'MR', not CT") && Contains(folders[1]));
  REQUIRE(ReadLabelMap(folders[1]).values == testing::SmallCt(2).values);
  // pydicom's own MR file.
  REQUIRE_THROWS_WITH(ReadCtImage(kPydicomFiles + "MR_small.dcm"), Contains("'MR', not CT") && Contains("MR_small.dcm"));
  REQUIRE(ReadLabelMap(kPydicomFiles + "MR_small.dcm").size == Eigen::Vector3i(64, 64, 1));
}

TEST_CASE("ct phases: phases on different grids are an error naming both phases and their values", "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_phases_grids");
  const CtImage first = testing::SmallCt();
  CtImage finer = first;
  finer.spacing_m.z() = 1.25e-3;
  CtImage shifted = first;
  shifted.origin_m.x() += 0.1e-3;
  CtImage bigger = testing::PatternCt({5, 4, 4}, first.spacing_m, first.origin_m, first.direction);
  int n = 0;
  for (const auto& [other, what] : {std::pair{finer, "spacing"}, {shifted, "origin"}, {bigger, "size"}}) {
    const std::string a = temporary.path() + "/a" + std::to_string(n),
                      b = temporary.path() + "/b" + std::to_string(n++);
    WriteDicomSeries(first, a, testing::PhaseInfo(a, 1, 2));
    WriteDicomSeries(other, b, testing::PhaseInfo(b, 2, 2));
    REQUIRE_THROWS_WITH(ReadCtPhases({a, b}, {}), Contains(std::string("the phases differ in ") + what) &&
                                                      Contains(a) && Contains(b) && Contains("1.5 mm") &&
                                                      Contains("fix:"));
  }
}

TEST_CASE("ct phases: missing, unreadable, truncated and unsupported files are errors naming them", "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_phases_unreadable");
  REQUIRE_THROWS_WITH(ReadCtImage(temporary.File("absent.nii.gz")),
                      Contains("no such file") && Contains("absent.nii.gz"));
  std::ofstream(temporary.File("notes.txt")) << "not an image\n";
  REQUIRE_THROWS_WITH(ReadCtImage(temporary.File("notes.txt")),
                      Contains("no image reader takes this file") && Contains(".nii.gz"));
  std::ofstream(temporary.File("garbage.mha")) << "ObjectType = Image\nNDims = 3\nDimSize = 10 10 10\n"
                                                  "ElementType = MET_SHORT\nElementDataFile = LOCAL\n"
                                               << "short";
  REQUIRE_THROWS_WITH(ReadCtImage(temporary.File("garbage.mha")),
                      Contains("truncated: 5 bytes where the header says 2000") && Contains("garbage.mha"));
  std::ofstream(temporary.File("garbage.nii.gz")) << "not gzip at all, and not NIfTI either";
  REQUIRE_THROWS_WITH(ReadCtImage(temporary.File("garbage.nii.gz")), Contains("garbage.nii.gz") && Contains("fix:"));
  fs::create_directories(temporary.File("empty"));
  REQUIRE_THROWS_WITH(ReadCtPhases({temporary.File("empty")}, {}),
                      Contains("no DICOM series in the folder or its subfolders") && Contains("empty"));
  // A series with a slice gone: unevenly spaced slices.
  CtImage tall = testing::PatternCt({4, 4, 5}, {1e-3, 1e-3, 2e-3}, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity());
  WriteDicomSeries(tall, temporary.File("gap"), testing::PhaseInfo("gap", 1, 1));
  fs::remove(temporary.File("gap/slice_0002.dcm"));
  REQUIRE_THROWS_WITH(ReadCtImage(temporary.File("gap")), Contains("unevenly spaced") && Contains("gap"));
}

}  // namespace
}  // namespace dg::io
