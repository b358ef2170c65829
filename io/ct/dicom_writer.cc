#include "io/ct/dicom_writer.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <vector>

// The system's Eigen modules before ITK's headers: ITK's bundled Eigen (3.3,
// same guards) then uses them instead of compiling its own against ours.
#include <Eigen/Dense>
#include <itkGDCMImageIO.h>
#include <itkImage.h>
#include <itkImageSeriesWriter.h>
#include <itkMetaDataObject.h>

#include "io/ct/itk_factories.h"
#include "sim/error.h"

namespace dg::io {
namespace {

namespace fs = std::filesystem;

// The stored range with intercept -1024 in an int16 buffer of HU.
constexpr double kMinHu = -32768, kMaxHu = 32767 - 1024;
constexpr char kCtImageStorage[] = "1.2.840.10008.5.1.4.1.1.2";
// The longest suffix a slice adds to the series UID: "." and up to five digits.
constexpr size_t kSliceSuffix = 6;

bool IsUid(const std::string& uid, size_t max_length = 64) {
  if (uid.empty() || uid.size() > max_length) return false;
  size_t start = 0;
  while (start <= uid.size()) {
    const size_t end = std::min(uid.find('.', start), uid.size());
    const std::string component = uid.substr(start, end - start);
    if (component.empty() || !std::all_of(component.begin(), component.end(), ::isdigit)) return false;
    if (component.size() > 1 && component.front() == '0') return false;
    start = end + 1;
  }
  return true;
}

// FNV-1a over the text from a given basis, then SplitMix64's finaliser.
uint64_t Hash64(std::string_view text, uint64_t basis) {
  uint64_t h = basis;
  for (unsigned char c : text) h = (h ^ c) * 0x100000001B3ULL;
  h ^= h >> 30;
  h *= 0xBF58476D1CE4E5B9ULL;
  h ^= h >> 27;
  h *= 0x94D049BB133111EBULL;
  return h ^ (h >> 31);
}

std::string Format(const char* format, double value) {
  char text[64];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

std::string Millimetres(double metres) { return Format("%.10g", 1e3 * metres); }

using SliceTags = std::vector<std::pair<const char*, std::string>>;

// What every slice of the series says.
SliceTags SeriesTags(const CtImage& ct, const DicomSeriesInfo& info) {
  const Eigen::Matrix3d& R = ct.direction;
  SliceTags tags = {
      {"0008|0008", "DERIVED\\SECONDARY\\AXIAL"},
      {"0008|0016", kCtImageStorage},
      {"0008|0060", "CT"},
      {"0008|1030", info.study_description},
      {"0008|103e", info.series_description},
      {"0010|0010", info.patient_name},
      {"0010|0020", info.patient_id},
      {"0018|0050", Millimetres(ct.spacing_m.z())},
      {"0018|0088", Millimetres(ct.spacing_m.z())},
      {"0020|000d", info.study_uid},
      {"0020|000e", info.series_uid},
      {"0020|0011", std::to_string(info.series_number)},
      {"0020|0037", Format("%.10g", R(0, 0)) + "\\" + Format("%.10g", R(1, 0)) + "\\" + Format("%.10g", R(2, 0)) +
                        "\\" + Format("%.10g", R(0, 1)) + "\\" + Format("%.10g", R(1, 1)) + "\\" +
                        Format("%.10g", R(2, 1))},
      {"0020|0052", info.frame_of_reference_uid.empty()
                        ? DeterministicUid("frame of reference of study " + info.study_uid)
                        : info.frame_of_reference_uid},
      {"0028|0004", "MONOCHROME2"},  // GDCM sets it too, but warns on every slice unless told first
      {"0028|1052", "-1024"},
      {"0028|1053", "1"},
      {"0028|1054", "HU"},
  };
  if (!info.date.empty()) {
    for (const char* key : {"0008|0012", "0008|0020", "0008|0021", "0008|0023"}) tags.push_back({key, info.date});
    for (const char* key : {"0008|0013", "0008|0030", "0008|0031", "0008|0033"}) tags.push_back({key, "000000"});
  }
  if (info.temporal_position > 0) {
    tags.push_back({"0020|0100", std::to_string(info.temporal_position)});
    tags.push_back({"0020|0105", std::to_string(info.temporal_positions)});
  }
  if (!std::isnan(info.cycle_fraction)) tags.push_back({"0020|9241", Format("%.6g", 100 * info.cycle_fraction)});
  if (!std::isnan(info.trigger_time_ms)) tags.push_back({"0018|1060", Format("%.6g", info.trigger_time_ms)});
  if (!std::isnan(info.heart_rate_bpm)) tags.push_back({"0018|1088", std::to_string(std::lround(info.heart_rate_bpm))});
  return tags;
}

}  // namespace

std::string DicomSeriesInfo::Validate() const {
  if (!IsUid(study_uid)) return "study UID '" + study_uid + "' is not a DICOM UID (digits and dots, at most 64)";
  if (!IsUid(series_uid, 64 - kSliceSuffix)) {
    return "series UID '" + series_uid + "' is not a DICOM UID of at most " + std::to_string(64 - kSliceSuffix) +
           " characters (each slice's UID appends its number)";
  }
  if (!frame_of_reference_uid.empty() && !IsUid(frame_of_reference_uid)) {
    return "frame of reference UID '" + frame_of_reference_uid + "' is not a DICOM UID";
  }
  if (patient_id.size() > 64) return "patient ID is longer than 64 characters";
  if (series_description.size() > 64 || study_description.size() > 64) return "a description is longer than 64 characters";
  if (series_number < 0) return "series number must not be negative";
  if (!date.empty() && (date.size() != 8 || !std::all_of(date.begin(), date.end(), ::isdigit))) {
    return "date '" + date + "' is not YYYYMMDD";
  }
  if (temporal_position < 0 || (temporal_position > 0 && temporal_position > temporal_positions)) {
    return "temporal position must lie in 1..temporal_positions (or be 0 for none)";
  }
  if (!std::isnan(cycle_fraction) && !(cycle_fraction >= 0 && cycle_fraction < 1)) {
    return "cycle fraction must lie in [0, 1)";
  }
  if (!std::isnan(heart_rate_bpm) && !(heart_rate_bpm > 0)) return "heart rate must be positive";
  return {};
}

std::string DeterministicUid(std::string_view text) {
  unsigned __int128 value = (static_cast<unsigned __int128>(Hash64(text, 0xCBF29CE484222325ULL)) << 64) |
                            Hash64(text, 0x84222325CBF29CE4ULL);
  std::string digits;
  do {
    digits.push_back(static_cast<char>('0' + static_cast<int>(value % 10)));
    value /= 10;
  } while (value != 0);
  std::reverse(digits.begin(), digits.end());
  return "2.25." + digits;
}

void WriteDicomSeries(const CtImage& ct, const std::string& folder, const DicomSeriesInfo& info) {
  if (const std::string wrong = info.Validate(); !wrong.empty()) {
    throw Error("invalid DICOM series information: " + wrong, folder, "correct the series information");
  }
  if (ct.num_voxels() == 0 || ct.values.size() != ct.num_voxels()) {
    throw Error("the CT to write is empty or its values do not fill its grid", folder, "give a complete CtImage");
  }
  if (ct.size.z() > 99999) throw Error("more than 99999 slices", folder, "write a smaller image");
  RegisterItkImageIo();
  std::error_code error;
  fs::create_directories(folder, error);
  if (error) throw Error("cannot create the folder: " + error.message(), folder, "check the parent is writable");

  using Volume = itk::Image<int16_t, 3>;
  using Slice = itk::Image<int16_t, 2>;
  auto image = Volume::New();
  Volume::SizeType size;
  for (int a = 0; a < 3; ++a) size[a] = static_cast<Volume::SizeValueType>(ct.size[a]);
  image->SetRegions(Volume::RegionType(size));
  Volume::SpacingType spacing;
  Volume::PointType origin;
  Volume::DirectionType direction;
  for (int a = 0; a < 3; ++a) {
    spacing[a] = 1e3 * ct.spacing_m[a];
    origin[a] = 1e3 * ct.origin_m[a];
    for (int b = 0; b < 3; ++b) direction(a, b) = ct.direction(a, b);
  }
  image->SetSpacing(spacing);
  image->SetOrigin(origin);
  image->SetDirection(direction);
  image->Allocate();
  int16_t* voxels = image->GetBufferPointer();
  for (size_t v = 0; v < ct.num_voxels(); ++v) {
    voxels[v] = static_cast<int16_t>(std::lround(std::clamp(static_cast<double>(ct.values[v]), kMinHu, kMaxHu)));
  }

  const SliceTags common = SeriesTags(ct, info);
  std::vector<itk::MetaDataDictionary> dictionaries(ct.size.z());
  std::vector<itk::MetaDataDictionary*> slices;
  std::vector<std::string> files;
  for (int k = 0; k < ct.size.z(); ++k) {
    itk::MetaDataDictionary& tags = dictionaries[k];
    for (const auto& [key, value] : common) itk::EncapsulateMetaData<std::string>(tags, key, value);
    const Eigen::Vector3d position = ct.PointOf(0, 0, k);
    itk::EncapsulateMetaData<std::string>(tags, "0008|0018", info.series_uid + "." + std::to_string(k + 1));
    itk::EncapsulateMetaData<std::string>(tags, "0020|0013", std::to_string(k + 1));
    itk::EncapsulateMetaData<std::string>(
        tags, "0020|0032", Millimetres(position.x()) + "\\" + Millimetres(position.y()) + "\\" + Millimetres(position.z()));
    itk::EncapsulateMetaData<std::string>(tags, "0020|1041", Millimetres(ct.direction.col(2).dot(position)));
    // PixelSpacing is row spacing (between rows, along j) then column spacing (along i).
    itk::EncapsulateMetaData<std::string>(tags, "0028|0030",
                                          Millimetres(ct.spacing_m.y()) + "\\" + Millimetres(ct.spacing_m.x()));
    slices.push_back(&tags);
    char name[32];
    std::snprintf(name, sizeof name, "slice_%04d.dcm", k);
    files.push_back((fs::path(folder) / name).string());
  }

  auto io = itk::GDCMImageIO::New();
  io->KeepOriginalUIDOn();  // the UIDs of the dictionaries, not GDCM's random ones
  auto writer = itk::ImageSeriesWriter<Volume, Slice>::New();
  writer->SetInput(image);
  writer->SetImageIO(io);
  writer->SetFileNames(files);
  writer->SetMetaDataDictionaryArray(&slices);
  try {
    writer->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("cannot write the DICOM series: ") + e.GetDescription(), folder,
                "check the folder is writable and has space");
  }
}

}  // namespace dg::io
