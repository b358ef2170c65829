#include "io/ct/dicom_series.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include <itkGDCMImageIO.h>
#include <itkGDCMSeriesFileNames.h>
#include <itkMetaDataObject.h>

#include "io/ct/itk_factories.h"
#include "sim/error.h"

namespace dg::io {
namespace {

std::string Trimmed(std::string text) {
  const auto first = text.find_first_not_of(" \t\r\n");
  const auto last = text.find_last_not_of(" \t\r\n");
  return first == std::string::npos ? std::string() : text.substr(first, last - first + 1);
}

std::string Tag(const itk::MetaDataDictionary& dictionary, const char* key) {
  std::string value;
  itk::ExposeMetaData<std::string>(dictionary, key, value);
  return Trimmed(value);
}

// A numeric tag (DS, IS, FL written as text by GDCM), NaN when absent or empty.
double NumberTag(const itk::MetaDataDictionary& dictionary, const char* key) {
  const std::string text = Tag(dictionary, key);
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  return text.empty() || end == text.c_str() ? PhaseTags::kNone : value;
}

DicomSeries TagsOf(const itk::MetaDataDictionary& dictionary, const std::string& where) {
  DicomSeries series;
  series.uid = Tag(dictionary, "0020|000e");
  series.modality = Tag(dictionary, "0008|0060");
  PhaseTags& tags = series.tags;
  tags.where = where;
  tags.series_uid = series.uid;
  tags.description = Tag(dictionary, "0008|103e");
  tags.nominal_percentage = NumberTag(dictionary, "0020|9241");
  tags.description_percentage = DescriptionPercentage(tags.description);
  const double position = NumberTag(dictionary, "0020|0100");
  const double positions = NumberTag(dictionary, "0020|0105");
  tags.temporal_position = std::isnan(position) ? 0 : static_cast<int>(std::lround(position));
  tags.temporal_positions = std::isnan(positions) ? 0 : static_cast<int>(std::lround(positions));
  tags.trigger_time_ms = NumberTag(dictionary, "0018|1060");
  tags.heart_rate_bpm = NumberTag(dictionary, "0018|1088");
  tags.respiratory_percentage = NumberTag(dictionary, "0020|9245");
  tags.respiratory_delay_ms = NumberTag(dictionary, "0020|9255");
  tags.respiratory_interval_ms = NumberTag(dictionary, "0020|9254");
  tags.name_percentage = NamePercentage(where);
  return series;
}

}  // namespace

DicomSeries ReadDicomFileTags(const std::string& file) {
  RegisterItkImageIo();
  auto io = itk::GDCMImageIO::New();
  if (!io->CanReadFile(file.c_str())) {
    throw Error("not a DICOM file GDCM can read", file, "check the file is a complete DICOM file");
  }
  try {
    io->SetFileName(file);
    io->ReadImageInformation();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("cannot read the DICOM header: ") + e.GetDescription(), file,
                "check the file is a complete DICOM file");
  }
  return TagsOf(io->GetMetaDataDictionary(), file);
}

std::vector<DicomSeries> ListDicomSeries(const std::string& folder) {
  RegisterItkImageIo();
  // A folder of per-phase subfolders holds no file itself: nothing for GDCM,
  // which would print a warning of its own to the terminal.
  std::error_code error;
  const bool has_files = std::any_of(std::filesystem::directory_iterator(folder, error),
                                     std::filesystem::directory_iterator(),
                                     [](const auto& entry) { return entry.is_regular_file(); });
  if (!has_files) return {};
  auto names = itk::GDCMSeriesFileNames::New();
  names->SetUseSeriesDetails(false);
  names->SetRecursive(false);
  std::vector<DicomSeries> list;
  try {
    names->SetDirectory(folder);
    for (const std::string& uid : names->GetSeriesUIDs()) {
      const std::vector<std::string>& files = names->GetFileNames(uid);
      if (files.empty()) continue;
      DicomSeries series = ReadDicomFileTags(files.front());
      series.folder = folder;
      series.uid = uid;
      series.files = files;
      series.tags.where = folder;
      series.tags.name_percentage = NamePercentage(folder);
      series.tags.series_uid = uid;
      list.push_back(std::move(series));
    }
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("cannot scan the folder for DICOM series: ") + e.GetDescription(), folder,
                "check the folder is readable");
  }
  return list;
}

std::string DescribeSeries(const std::vector<DicomSeries>& series) {
  std::string text;
  for (const DicomSeries& s : series) {
    text += (text.empty() ? "" : "; ") + s.tags.Describe() + " " + s.modality + ", " +
            std::to_string(s.files.size()) + " files";
  }
  return text;
}

}  // namespace dg::io
