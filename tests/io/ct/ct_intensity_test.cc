// The intensity check: real CTs in HU are accepted; an 8-bit image, an MR
// image and a CT stored without its rescale are refused with the fixes; a
// scale given by the user makes stored values HU; --not-hu takes them as
// they are and marks them.
#include <algorithm>
#include <filesystem>
#include <functional>

// The system's Eigen modules before ITK's headers: ITK's bundled Eigen (3.3,
// same guards) then uses them instead of compiling its own against ours.
#include <Eigen/Dense>
#include <catch2/catch.hpp>

#include "io/ct/ct_reader.h"
#include "io/metaimage.h"
#include "tests/support/temporary_folder.h"
#include "tests/support/real_data.h"

namespace dg::io {
namespace {

using Catch::Matchers::Contains;

std::string Abdomen(const std::string& file) { return dg::testing::RealData("03_ct_abdomen_totalseg/" + file); }
// Debian's python3-nibabel test images (nibabel/tests/data/README.rst).
const std::string kNibabelData = "/usr/lib/python3/dist-packages/nibabel/tests/data/";

// The message of the dg::Error that `read` throws, after checking it is the intensity refusal of `file`.
std::string Refusal(const std::function<void()>& read, const std::string& file) {
  std::string message = "no error";
  try {
    read();
  } catch (const std::exception& e) {
    message = e.what();
  }
  REQUIRE_THAT(message, Contains("do not look like a CT in Hounsfield units") && Contains(file) &&
                            Contains("--intensity-scale SLOPE,INTERCEPT") && Contains("--not-hu") &&
                            Contains("give a CT in Hounsfield units"));
  return message;
}

TEST_CASE("ct intensity: real CTs in HU are accepted", "[integration]") {
  // The data README.txt: a Siemens abdominal CT, DICOM (-1024..1839 HU) and NIfTI (-1207..3382 HU).
  for (const std::string& path : {Abdomen("dicom_raw"), Abdomen("ct_abdomen_3mm_30slices.nii.gz")}) {
    INFO(path);
    const CtImage ct = ReadCtImage(path);
    REQUIRE(ct.values_are_hu);
    REQUIRE(*std::min_element(ct.values.begin(), ct.values.end()) < -1000);
  }
  REQUIRE(ReadCtImage(Abdomen("dicom_raw")).modality == "CT");
}

TEST_CASE("ct intensity: an 8-bit image and an MR image are refused, or taken as they are with --not-hu",
          "[integration]") {
  // nibabel's standard.nii.gz: 4 x 5 x 7, uint8, 0..255.
  const std::string eight_bit = kNibabelData + "standard.nii.gz";
  REQUIRE_THAT(Refusal([&] { ReadCtImage(eight_bit); }, "standard.nii.gz"),
               Contains("values 0..255") && Contains("0% of voxels below -200 HU") &&
                   Contains("0..255 is what an 8-bit image holds"));
  const CtImage as_stored = ReadCtImage(eight_bit, {.intensity = CtIntensity::kNotHu});
  REQUIRE(!as_stored.values_are_hu);
  REQUIRE(as_stored.size == Eigen::Vector3i(4, 5, 7));
  REQUIRE(*std::max_element(as_stored.values.begin(), as_stored.values.end()) == 255);
  // nibabel's anatomical.nii: a T1 MR, int16, -610..30393, 0.024% of its voxels below -200 and its
  // median above -200 at 8936 (numpy).
  REQUIRE_THAT(Refusal([&] { ReadCtImage(kNibabelData + "anatomical.nii"); }, "anatomical.nii"),
               Contains("-610..30393") && Contains("0.0237% of voxels") && Contains("median above -200 HU 8936 "));
}

TEST_CASE("ct intensity: a real CT stored without its rescale is refused, and read with the scale given",
          "[integration]") {
  const testing::TemporaryFolder temporary("dg_ct_intensity");
  // The real CT's stored values (HU + 1024, as its DICOM stores them: RescaleIntercept -1024), written
  // where no reader applies the rescale.
  const CtImage hu = ReadCtImage(Abdomen("dicom_raw"));
  VolumeI16 stored;
  stored.size = hu.size;
  stored.spacing_m = hu.spacing_m;
  stored.origin_m = hu.origin_m;
  for (float v : hu.values) stored.values.push_back(static_cast<int16_t>(v + 1024));
  WriteMetaImage(temporary.File("stored.mhd"), stored);

  REQUIRE_THAT(Refusal([&] { ReadCtImage(temporary.File("stored.mhd")); }, "stored.mhd"), Contains("values 0..2863"));
  CtReadOptions scale;
  scale.intensity = CtIntensity::kScale;
  scale.intensity_slope = 1;
  scale.intensity_intercept = -1024;
  const CtImage scaled = ReadCtImage(temporary.File("stored.mhd"), scale);
  REQUIRE(scaled.values_are_hu);
  REQUIRE(scaled.values == hu.values);
  // A scale that leaves it unlike HU is refused as well: the check comes after the scale.
  scale.intensity_intercept = 0;
  Refusal([&] { ReadCtImage(temporary.File("stored.mhd"), scale); }, "stored.mhd");
  scale.intensity_slope = 0;
  REQUIRE_THROWS_WITH(ReadCtImage(temporary.File("stored.mhd"), scale),
                      Contains("must be finite with a non-zero slope") && Contains("fix:"));
}

TEST_CASE("ct intensity: the rule's figures on small images", "[unit]") {
  CtImage ct;
  ct.size = {10, 10, 10};
  ct.source = "synthetic";
  // 1 voxel in 1000 of air is enough; none is not.
  ct.values.assign(1000, 40);
  ct.values[0] = -1000;
  REQUIRE_NOTHROW(CheckHounsfield(ct));
  ct.values[0] = -150;
  REQUIRE_THROWS_WITH(CheckHounsfield(ct), Contains("0% of voxels below -200 HU") && Contains("synthetic"));
  // Air with tissue of 500 HU is the highest median taken, 600 is not (bone, or a CT offset by its rescale).
  ct.values.assign(1000, 500);
  std::fill(ct.values.begin(), ct.values.begin() + 400, -1000.f);
  REQUIRE_NOTHROW(CheckHounsfield(ct));
  std::fill(ct.values.begin() + 400, ct.values.end(), 600.f);
  REQUIRE_THROWS_WITH(CheckHounsfield(ct), Contains("median above -200 HU 600 "));
  // All air: nothing to judge the tissue by, accepted.
  ct.values.assign(1000, -1000);
  REQUIRE_NOTHROW(CheckHounsfield(ct));
  ct.modality = "CT";
  ct.values.assign(1000, 0);
  REQUIRE_THROWS_WITH(CheckHounsfield(ct), Contains("DICOM modality CT"));
}

}  // namespace
}  // namespace dg::io
