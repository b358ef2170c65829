#include "io/metaimage.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

#include "sim/error.h"

namespace dg::io {
namespace {

// The .raw is written and read as the machine stores it.
static_assert(std::endian::native == std::endian::little,
              "MetaImage I/O assumes a little-endian host");

constexpr double kMmPerM = 1e3;
const std::string kResave =
    "save the volume again as an uncompressed .mhd/.raw pair (e.g. from 3D Slicer or ITK)";

template <typename T>
constexpr const char* ElementType() {
  if constexpr (std::is_same_v<T, std::int16_t>) return "MET_SHORT";
  if constexpr (std::is_same_v<T, std::uint8_t>) return "MET_UCHAR";
  if constexpr (std::is_same_v<T, float>) return "MET_FLOAT";
}

std::string Trim(const std::string& text) {
  const auto space = [](unsigned char c) { return std::isspace(c); };
  const auto begin = std::find_if_not(text.begin(), text.end(), space);
  const auto end = std::find_if_not(text.rbegin(), text.rend(), space).base();
  return begin < end ? std::string(begin, end) : std::string();
}

std::string Lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return text;
}

// Whitespace-separated numbers; nullopt if any token is not one.
std::optional<std::vector<double>> ParseNumbers(const std::string& text) {
  std::vector<double> numbers;
  std::istringstream tokens(text);
  for (std::string token; tokens >> token;) {
    double value;
    const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (error != std::errc() || end != token.data() + token.size()) return std::nullopt;
    numbers.push_back(value);
  }
  return numbers;
}

// The "Key = Value" lines of a header, each remembered with its line number
// so that an error can point at it.
class Header {
 public:
  explicit Header(const std::string& path) : path_(path) {
    std::ifstream in(path);
    if (!in) throw Error("cannot open MetaImage header", path, "check the path");
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
      if (Trim(line).empty()) continue;
      const size_t equals = line.find('=');
      if (equals == std::string::npos) {
        throw Error("expected 'Key = Value', found '" + line + "'", At(number),
                    "correct the line, or " + kResave);
      }
      const std::string key = Trim(line.substr(0, equals));
      if (entries_.count(key)) {
        throw Error("key " + key + " given again (first on line " +
                        std::to_string(entries_[key].line) + ")",
                    At(number), "keep one of the two lines");
      }
      entries_[key] = {Trim(line.substr(equals + 1)), number};
      // MetaIO ends the header here; what follows may be the data itself.
      if (key == "ElementDataFile") break;
    }
  }

  bool Has(const std::string& key) const { return entries_.count(key) > 0; }

  // The first of `keys` (a MetaIO name and its aliases) present, or nullptr.
  const char* Find(std::initializer_list<const char*> keys) const {
    for (const char* key : keys) {
      if (Has(key)) return key;
    }
    return nullptr;
  }

  const std::string& Text(const std::string& key) const {
    if (!Has(key)) {
      throw Error("missing key " + key, path_ + ": key " + key,
                  "add the line '" + key + " = ...', or " + kResave);
    }
    return entries_.at(key).value;
  }

  // Exactly `count` numbers under `key`, which must be present.
  std::vector<double> Numbers(const std::string& key, size_t count) const {
    const std::optional<std::vector<double>> numbers = ParseNumbers(Text(key));
    if (!numbers || numbers->size() != count) {
      Fail(key, "expected " + std::to_string(count) + " numbers, found '" + Text(key) + "'");
    }
    return *numbers;
  }

  // Numbers() under the first of `keys` present, or `fallback` when none is.
  std::vector<double> NumbersOr(std::initializer_list<const char*> keys,
                                const std::vector<double>& fallback) const {
    const char* key = Find(keys);
    return key ? Numbers(key, fallback.size()) : fallback;
  }

  // True/False under the first of `keys` present, or `fallback` when none is.
  bool Flag(std::initializer_list<const char*> keys, bool fallback) const {
    const char* key = Find(keys);
    if (!key) return fallback;
    const std::string value = Lower(Text(key));
    if (value != "true" && value != "false") {
      Fail(key, "expected True or False, found '" + Text(key) + "'");
    }
    return value == "true";
  }

  [[noreturn]] void Fail(const std::string& key, const std::string& problem,
                         const std::string& fix = "") const {
    // A key that is absent (e.g. BinaryData, False by default) is named instead of a line.
    throw Error(key + ": " + problem, Has(key) ? At(entries_.at(key).line) : path_ + ": key " + key,
                fix.empty() ? "correct the line, or " + kResave : fix);
  }

  const std::string& path() const { return path_; }

 private:
  std::string At(int line) const { return path_ + ":" + std::to_string(line); }

  struct Entry {
    std::string value;
    int line;
  };
  std::string path_;
  std::map<std::string, Entry> entries_;
};

// Refuses what would change the voxels' meaning if it were ignored.
void CheckSupported(const Header& header, const char* element_type) {
  if (header.Has("ObjectType") && header.Text("ObjectType") != "Image") {
    header.Fail("ObjectType", "expected Image, found '" + header.Text("ObjectType") + "'");
  }
  if (header.Numbers("NDims", 1)[0] != 3) {
    header.Fail("NDims", "only 3-D volumes are read", "give a 3-D volume");
  }
  if (header.NumbersOr({"ElementNumberOfChannels"}, {1.0})[0] != 1) {
    header.Fail("ElementNumberOfChannels", "only single-channel volumes are read",
                "extract one channel (component) first");
  }
  if (const char* key = header.Find({"TransformMatrix", "Rotation", "Orientation"})) {
    const std::vector<double> matrix = header.Numbers(key, 9);
    for (int i = 0; i < 9; ++i) {
      if (std::abs(matrix[i] - (i % 4 == 0 ? 1.0 : 0.0)) > 1e-6) {
        header.Fail(key, "only axis-aligned volumes (identity matrix) are read",
                    "resample the volume onto an axis-aligned grid (in 3D Slicer: harden the "
                    "transform, then Resample Scalar Volume)");
      }
    }
  }
  if (!header.Flag({"BinaryData"}, false)) {
    header.Fail("BinaryData", "only binary data is read", kResave);
  }
  if (header.Flag({"BinaryDataByteOrderMSB", "ElementByteOrderMSB"}, false)) {
    header.Fail(header.Find({"BinaryDataByteOrderMSB", "ElementByteOrderMSB"}),
                "big-endian data is not read", kResave);
  }
  if (header.Flag({"CompressedData"}, false)) {
    header.Fail("CompressedData", "compressed data is not read", kResave);
  }
  if (header.Text("ElementType") != element_type) {
    header.Fail(
        "ElementType",
        "expected " + std::string(element_type) + ", found '" + header.Text("ElementType") + "'",
        "read the volume with the type the file holds");
  }
}

// Reads the voxels from the data file, which must hold exactly as many bytes
// as DimSize and ElementType need after HeaderSize bytes (-1: at its end).
template <typename T>
void ReadData(const Header& header, Volume<T>* volume) {
  const std::string& name = header.Text("ElementDataFile");
  if (name == "LOCAL" || name == "LIST" || name.find('%') != std::string::npos) {
    header.Fail("ElementDataFile", "only a single separate data file is read", kResave);
  }
  const std::string raw_path = (std::filesystem::path(header.path()).parent_path() / name).string();
  std::error_code error;
  const std::uintmax_t bytes = std::filesystem::file_size(raw_path, error);
  if (error) {
    throw Error("cannot open MetaImage data file", raw_path,
                "put it beside the header, or correct ElementDataFile in " + header.path());
  }
  const std::uintmax_t expected = volume->num_voxels() * sizeof(T);
  const double header_size = header.NumbersOr({"HeaderSize"}, {0.0})[0];
  if (header_size < -1 || header_size != static_cast<std::intmax_t>(header_size)) {
    header.Fail("HeaderSize", "expected a byte count or -1");
  }
  const std::uintmax_t skip = header_size >= 0 ? static_cast<std::uintmax_t>(header_size)
                                               : bytes - std::min(bytes, expected);
  if (bytes != skip + expected) {
    throw Error("the data file holds " + std::to_string(bytes) + " bytes; DimSize and " +
                    "ElementType in " + header.path() + " need " + std::to_string(skip + expected),
                raw_path,
                bytes < skip + expected ? "the file is truncated; copy or write it again"
                                        : "correct DimSize or ElementType in the header");
  }
  volume->values.resize(volume->num_voxels());
  std::ifstream raw(raw_path, std::ios::binary);
  raw.seekg(static_cast<std::streamoff>(skip));
  raw.read(reinterpret_cast<char*>(volume->values.data()), static_cast<std::streamsize>(expected));
  if (!raw) throw Error("cannot read MetaImage data file", raw_path, "check that it is readable");
}

template <typename T>
void ReadGrid(const Header& header, Volume<T>* volume) {
  const std::vector<double> size = header.Numbers("DimSize", 3);
  const std::vector<double> spacing_mm = header.Numbers("ElementSpacing", 3);
  const std::vector<double> origin_mm =
      header.NumbersOr({"Offset", "Origin", "Position"}, {0, 0, 0});
  for (int d = 0; d < 3; ++d) {
    if (size[d] < 1 || size[d] != static_cast<int>(size[d])) {
      header.Fail("DimSize", "sizes must be positive integers");
    }
    if (!(spacing_mm[d] > 0)) header.Fail("ElementSpacing", "spacings must be positive");
    volume->size[d] = static_cast<int>(size[d]);
    volume->spacing_m[d] = spacing_mm[d] / kMmPerM;
    volume->origin_m[d] = origin_mm[d] / kMmPerM;
  }
}

}  // namespace

template <typename T>
void WriteMetaImage(const std::string& mhd_path, const Volume<T>& volume) {
  DG_CHECK(volume.values.size() == volume.num_voxels());
  const std::filesystem::path header_path(mhd_path);
  if (header_path.extension() != ".mhd") {
    throw Error("a MetaImage header's name must end in .mhd", mhd_path, "name it NAME.mhd");
  }
  const std::filesystem::path raw_path =
      std::filesystem::path(header_path).replace_extension(".raw");
  // Shortest text that reads back to the same double.
  const auto mm = [](const Eigen::Vector3d& v_m) {
    std::string text;
    for (int d = 0; d < 3; ++d) {
      char buffer[32];
      const auto end = std::to_chars(buffer, buffer + sizeof(buffer), v_m[d] * kMmPerM).ptr;
      if (d) text += ' ';
      text.append(buffer, end);
    }
    return text;
  };
  std::ofstream header(header_path);
  // ElementDataFile must come last: MetaIO stops reading the header there.
  header << "ObjectType = Image\n"
         << "NDims = 3\n"
         << "BinaryData = True\n"
         << "BinaryDataByteOrderMSB = False\n"
         << "CompressedData = False\n"
         << "TransformMatrix = 1 0 0 0 1 0 0 0 1\n"
         << "Offset = " << mm(volume.origin_m) << "\n"
         << "CenterOfRotation = 0 0 0\n"
         << "AnatomicalOrientation = RAI\n"
         << "ElementSpacing = " << mm(volume.spacing_m) << "\n"
         << "DimSize = " << volume.size.x() << " " << volume.size.y() << " " << volume.size.z()
         << "\n"
         << "ElementType = " << ElementType<T>() << "\n"
         << "ElementDataFile = " << raw_path.filename().string() << "\n";
  header.close();
  if (!header) throw Error("cannot write MetaImage header", mhd_path, "check the directory");
  std::ofstream raw(raw_path, std::ios::binary);
  raw.write(reinterpret_cast<const char*>(volume.values.data()),
            static_cast<std::streamsize>(volume.values.size() * sizeof(T)));
  raw.close();
  if (!raw) throw Error("cannot write MetaImage data", raw_path.string(), "check free space");
}

Volume<std::uint8_t> ReadMetaImageGrid(const std::string& mhd_path) {
  const Header header(mhd_path);
  Volume<std::uint8_t> grid;
  ReadGrid(header, &grid);
  return grid;
}

template <typename T>
Volume<T> ReadMetaImage(const std::string& mhd_path) {
  const Header header(mhd_path);
  CheckSupported(header, ElementType<T>());
  Volume<T> volume;
  ReadGrid(header, &volume);
  ReadData(header, &volume);
  return volume;
}

template void WriteMetaImage(const std::string&, const VolumeI16&);
template void WriteMetaImage(const std::string&, const VolumeU8&);
template void WriteMetaImage(const std::string&, const VolumeF32&);
template VolumeI16 ReadMetaImage(const std::string&);
template VolumeU8 ReadMetaImage(const std::string&);
template VolumeF32 ReadMetaImage(const std::string&);

}  // namespace dg::io
