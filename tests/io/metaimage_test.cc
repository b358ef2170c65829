#include "io/metaimage.h"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "sim/error.h"

namespace dg::io {
namespace {

std::string OutputPath(const std::string& name) { return std::string(DG_BINARY_DIR) + "/" + name; }

// A 3 x 4 x 5 volume whose voxel (i, j, k) holds 100 i + 10 j + k - 200, so
// that any mix-up of axes or strides shows.
template <typename T>
Volume<T> Ramp() {
  Volume<T> volume;
  volume.size = {3, 4, 5};
  volume.spacing_m = {0.5e-3, 0.75e-3, 1.25e-3};
  volume.origin_m = {-12.5e-3, 3e-3, 0.1e-3};
  volume.values.resize(volume.num_voxels());
  for (int k = 0; k < 5; ++k) {
    for (int j = 0; j < 4; ++j) {
      for (int i = 0; i < 3; ++i) volume.at(i, j, k) = static_cast<T>(100 * i + 10 * j + k - 200);
    }
  }
  return volume;
}

std::vector<char> ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void WriteText(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

template <typename T>
Error ReadError(const std::string& path) {
  try {
    ReadMetaImage<T>(path);
  } catch (const Error& error) {
    return error;
  }
  FAIL("no error reading " << path);
  throw;  // unreachable: FAIL throws
}

template <typename T>
void RequireSameVolume(const Volume<T>& read, const Volume<T>& written) {
  REQUIRE(read.size == written.size);
  REQUIRE(read.values == written.values);
  // Through millimetres and back: equal to rounding.
  REQUIRE((read.spacing_m - written.spacing_m).cwiseAbs().maxCoeff() < 1e-18);
  REQUIRE((read.origin_m - written.origin_m).cwiseAbs().maxCoeff() < 1e-18);
}

}  // namespace

// Volumes of each element type read back with their size, spacing, origin and values.
TEST_CASE("metaimage: round trip of int16, uint8 and float volumes", "[io][unit]") {
  const VolumeI16 ct = Ramp<std::int16_t>();
  WriteMetaImage(OutputPath("metaimage_i16.mhd"), ct);
  RequireSameVolume(ReadMetaImage<std::int16_t>(OutputPath("metaimage_i16.mhd")), ct);

  VolumeU8 labels = Ramp<std::uint8_t>();
  for (auto& value : labels.values) value = static_cast<std::uint8_t>(value % 7);
  WriteMetaImage(OutputPath("metaimage_u8.mhd"), labels);
  RequireSameVolume(ReadMetaImage<std::uint8_t>(OutputPath("metaimage_u8.mhd")), labels);

  VolumeF32 density = Ramp<float>();
  for (auto& value : density.values) value *= 0.125f;
  WriteMetaImage(OutputPath("metaimage_f32.mhd"), density);
  RequireSameVolume(ReadMetaImage<float>(OutputPath("metaimage_f32.mhd")), density);
}

// The header has every key MetaIO's spec and 3D Slicer need, in millimetres,
// with ElementDataFile last; the .raw holds the voxels x fastest, nothing else.
TEST_CASE("metaimage: header keys and raw layout follow the MetaImage spec", "[io][unit]") {
  const VolumeI16 ct = Ramp<std::int16_t>();
  const std::string mhd = OutputPath("metaimage_spec.mhd");
  WriteMetaImage(mhd, ct);

  std::ifstream header(mhd);
  std::map<std::string, std::string> keys;
  std::string line, last_key;
  while (std::getline(header, line)) {
    const size_t equals = line.find(" = ");
    REQUIRE(equals != std::string::npos);
    last_key = line.substr(0, equals);
    REQUIRE(keys.emplace(last_key, line.substr(equals + 3)).second);
  }
  const std::map<std::string, std::string> expected = {{"ObjectType", "Image"},
                                                       {"NDims", "3"},
                                                       {"BinaryData", "True"},
                                                       {"BinaryDataByteOrderMSB", "False"},
                                                       {"CompressedData", "False"},
                                                       {"TransformMatrix", "1 0 0 0 1 0 0 0 1"},
                                                       {"Offset", "-12.5 3 0.1"},
                                                       {"CenterOfRotation", "0 0 0"},
                                                       {"AnatomicalOrientation", "RAI"},
                                                       {"ElementSpacing", "0.5 0.75 1.25"},
                                                       {"DimSize", "3 4 5"},
                                                       {"ElementType", "MET_SHORT"},
                                                       {"ElementDataFile", "metaimage_spec.raw"}};
  REQUIRE(keys == expected);
  REQUIRE(last_key == "ElementDataFile");

  const std::vector<char> raw = ReadBytes(OutputPath("metaimage_spec.raw"));
  REQUIRE(raw.size() == 3 * 4 * 5 * sizeof(std::int16_t));
  for (int k = 0; k < 5; ++k) {
    for (int j = 0; j < 4; ++j) {
      for (int i = 0; i < 3; ++i) {
        std::int16_t value;
        std::memcpy(&value, raw.data() + 2 * (i + 3 * (j + 4 * k)), 2);
        REQUIRE(value == 100 * i + 10 * j + k - 200);
      }
    }
  }
  WriteMetaImage(OutputPath("metaimage_spec_f32.mhd"), Ramp<float>());
  REQUIRE(std::filesystem::file_size(OutputPath("metaimage_spec_f32.raw")) == 3 * 4 * 5 * 4);
}

// A header as another tool might write it (other key order, aliases, extra
// keys, CRLF) reads; mistakes are errors naming the file and line or key.
TEST_CASE("metaimage: tolerant reader, errors at file:line and key", "[io][unit]") {
  const VolumeI16 ct = Ramp<std::int16_t>();
  WriteMetaImage(OutputPath("metaimage_other.mhd"), ct);  // for its .raw
  const std::string mhd = OutputPath("metaimage_other.mhd");
  const std::string body =
      "NDims = 3\r\nComment = written by hand\r\nDimSize = 3 4 5\r\nElementType = MET_SHORT\r\n"
      "ElementSpacing = 0.5 0.75 1.25\r\nOrigin = -12.5 3 0.1\r\nElementNumberOfChannels = 1\r\n"
      "BinaryData = true\r\nElementByteOrderMSB = False\r\n";
  WriteText(mhd, "ObjectType = Image\n" + body + "ElementDataFile = metaimage_other.raw\n");
  RequireSameVolume(ReadMetaImage<std::int16_t>(mhd), ct);

  SECTION("a line without '='") {
    WriteText(mhd, "ObjectType = Image\nNDims 3\n");
    const Error error = ReadError<std::int16_t>(mhd);
    REQUIRE(error.where() == mhd + ":2");
  }
  SECTION("a missing key") {
    WriteText(mhd,
              "NDims = 3\nElementType = MET_SHORT\nBinaryData = True\n"
              "ElementDataFile = metaimage_other.raw\n");
    const Error error = ReadError<std::int16_t>(mhd);
    REQUIRE(error.where() == mhd + ": key DimSize");
  }
  SECTION("a malformed value") {
    WriteText(mhd, "ObjectType = Image\n" + body + "DimSize = 3 4\n");
    const Error twice = ReadError<std::int16_t>(mhd);
    REQUIRE(twice.where() == mhd + ":11");
    REQUIRE_THAT(twice.problem(), Catch::Contains("DimSize") && Catch::Contains("line 4"));
    std::string bad_spacing = body;
    const size_t spacing = bad_spacing.find("0.75");
    REQUIRE(spacing != std::string::npos);
    bad_spacing.replace(spacing, 4, 1, 'x');
    WriteText(mhd, bad_spacing + "ElementDataFile = metaimage_other.raw\n");
    REQUIRE(ReadError<std::int16_t>(mhd).where() == mhd + ":5");
    WriteText(mhd, "NDims = 3\nElementType = MET_SHORT\nElementDataFile = metaimage_other.raw\n");
    REQUIRE(ReadError<std::int16_t>(mhd).where() == mhd + ": key BinaryData");
  }
  SECTION("another element type") {
    WriteText(mhd, "ObjectType = Image\n" + body + "ElementDataFile = metaimage_other.raw\n");
    const Error error = ReadError<float>(mhd);
    REQUIRE(error.where() == mhd + ":5");
    REQUIRE_THAT(error.problem(), Catch::Contains("MET_FLOAT") && Catch::Contains("MET_SHORT"));
  }
  SECTION("compressed data") {
    WriteText(mhd, body + "CompressedData = True\nElementDataFile = metaimage_other.raw\n");
    REQUIRE(ReadError<std::int16_t>(mhd).where() == mhd + ":10");
  }
}

// A .raw shorter than DimSize and ElementType need is an error naming the
// .raw, not a volume with garbage at its end.
TEST_CASE("metaimage: a truncated raw file is an error", "[io][unit]") {
  const std::string mhd = OutputPath("metaimage_truncated.mhd");
  const std::string raw = OutputPath("metaimage_truncated.raw");
  WriteMetaImage(mhd, Ramp<float>());
  std::filesystem::resize_file(raw, 3 * 4 * 5 * 4 - 1);
  const Error error = ReadError<float>(mhd);
  REQUIRE(error.where() == raw);
  REQUIRE_THAT(error.problem(), Catch::Contains("239 bytes") && Catch::Contains("need 240"));
  REQUIRE_THAT(error.fix(), Catch::Contains("truncated"));
  std::filesystem::remove(raw);
  REQUIRE(ReadError<float>(mhd).where() == raw);
}

}  // namespace dg::io
