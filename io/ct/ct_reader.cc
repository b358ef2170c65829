#include "io/ct/ct_reader.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>

// The system's Eigen modules before ITK's headers: ITK's bundled Eigen (3.3,
// same guards) then uses them instead of compiling its own against ours.
#include <Eigen/Dense>
#include <itkGDCMImageIO.h>
#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkImageIOFactory.h>
#include <itkImageSeriesReader.h>
#include <itkMetaDataObject.h>
#include <itkMetaImageIO.h>

#include "io/ct/axis_aligned.h"
#include "io/ct/dicom_series.h"
#include "io/ct/itk_factories.h"
#include "io/ct/phase_order.h"
#include "sim/error.h"
#include "sim/log.h"

namespace dg::io {
namespace {

namespace fs = std::filesystem;
using FloatImage = itk::Image<float, 3>;

constexpr char kFormats[] = ".nii, .nii.gz, .nrrd, .nhdr, .mhd, .mha, or a folder of one DICOM series";

// ITK's frame is in millimetres (DICOM's, and MetaImage's and NIfTI's as ITK reads them).
CtImage FromItk(const FloatImage& image, const std::string& source) {
  CtImage ct;
  const auto size = image.GetLargestPossibleRegion().GetSize();
  for (int a = 0; a < 3; ++a) {
    ct.size[a] = static_cast<int>(size[a]);
    ct.spacing_m[a] = 1e-3 * image.GetSpacing()[a];
    ct.origin_m[a] = 1e-3 * image.GetOrigin()[a];
    for (int b = 0; b < 3; ++b) ct.direction(a, b) = image.GetDirection()(a, b);
  }
  ct.values.assign(image.GetBufferPointer(), image.GetBufferPointer() + ct.num_voxels());
  ct.source = source;
  return ct;
}

void CheckModality(const std::string& modality, const std::string& where) {
  if (modality == "CT") return;
  throw Error("the DICOM modality is " + (modality.empty() ? std::string("missing") : "'" + modality + "'") +
                  ", not CT, where a CT is expected",
              where, "give the CT series (a label map of any modality is read as a label map)");
}

std::string Millimetres(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g mm", value);
  return text;
}

CtImage ReadSeries(const DicomSeries& series, bool require_ct) {
  const std::string where = series.folder + " (series " + series.uid + ")";
  if (require_ct) CheckModality(series.modality, where);
  auto reader = itk::ImageSeriesReader<FloatImage>::New();
  reader->SetImageIO(itk::GDCMImageIO::New());
  reader->SetFileNames(series.files);
  try {
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("cannot read the DICOM series: ") + e.GetDescription(), where,
                "check that every file of the series is complete");
  }
  std::set<std::string> positions;
  const auto& slices = *reader->GetMetaDataDictionaryArray();
  for (size_t s = 0; s < slices.size(); ++s) {
    std::string modality, position;
    itk::ExposeMetaData<std::string>(*slices[s], "0008|0060", modality);
    itk::ExposeMetaData<std::string>(*slices[s], "0020|0032", position);
    modality.erase(modality.find_last_not_of(' ') + 1);
    if (require_ct) CheckModality(modality, series.files[s]);
    positions.insert(position);
  }
  if (positions.size() < series.files.size()) {
    throw Error("the series holds several volumes: " + std::to_string(series.files.size()) + " files at " +
                    std::to_string(positions.size()) + " slice positions (e.g. every phase in one series)",
                where, "export one series per phase, or one folder per phase");
  }
  const FloatImage& image = *reader->GetOutput();
  double deviation = 0;
  itk::ExposeMetaData<double>(image.GetMetaDataDictionary(), "ITK_non_uniform_sampling_deviation", deviation);
  // DICOM writes positions as decimal text: a hundredth of the spacing is
  // rounding, a whole slice's worth is a missing slice.
  if (deviation > 0.01 * image.GetSpacing()[2]) {
    throw Error("the slices are unevenly spaced (spacing " + Millimetres(image.GetSpacing()[2]) +
                    ", deviating by up to " + Millimetres(deviation) + "): a slice is missing or the series mixes scans",
                where, "give a complete series of evenly spaced slices");
  }
  CtImage ct = FromItk(image, series.folder);
  ct.series_uid = series.uid;
  ct.modality = series.modality;
  return ct;
}

// MetaIO reports a data file shorter than its header says on stderr only, and
// ITK reads on: the voxels past the end would be garbage. Compressed data and
// file lists are left to their readers.
void CheckMetaImageDataSize(itk::ImageIOBase& io, const std::string& path) {
  auto* meta = dynamic_cast<itk::MetaImageIO*>(&io);
  if (!meta || meta->GetMetaImagePointer()->CompressedData()) return;
  const std::string data = meta->GetMetaImagePointer()->ElementDataFileName();
  std::uintmax_t available = 0;
  if (data == "LOCAL") {
    // The data follow the line that names them, the header's last.
    std::ifstream in(path, std::ios::binary);
    std::string head(1 << 16, '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<size_t>(in.gcount()));
    const size_t key = head.find("ElementDataFile");
    const size_t end = key == std::string::npos ? std::string::npos : head.find('\n', key);
    if (end == std::string::npos) return;
    available = fs::file_size(path) - (end + 1);
  } else if (data != "LIST" && data.find('%') == std::string::npos) {
    const fs::path file = fs::path(path).parent_path() / data;
    if (!fs::exists(file)) throw Error("the image's data file " + file.string() + " is missing", path, "put it beside the header");
    available = fs::file_size(file);
  } else {
    return;
  }
  const std::uintmax_t expected = io.GetImageSizeInBytes();
  if (available < expected) {
    throw Error("the image's data are truncated: " + std::to_string(available) + " bytes where the header says " +
                    std::to_string(expected),
                path, "write or copy the file again completely");
  }
}

CtImage ReadImageFile(const std::string& path, bool require_ct) {
  RegisterItkImageIo();
  itk::ImageIOBase::Pointer io = itk::ImageIOFactory::CreateImageIO(path.c_str(), itk::IOFileModeEnum::ReadMode);
  if (!io) throw Error("no image reader takes this file", path, std::string("give one of ") + kFormats);
  auto reader = itk::ImageFileReader<FloatImage>::New();
  try {
    io->SetFileName(path);
    io->ReadImageInformation();
    for (unsigned d = 3; d < io->GetNumberOfDimensions(); ++d) {
      if (io->GetDimensions(d) > 1) {
        throw Error("a " + std::to_string(io->GetNumberOfDimensions()) + "-D image where one 3-D phase is expected",
                    path, "split it into one file per phase");
      }
    }
    if (io->GetNumberOfComponents() != 1) {
      throw Error("an image of " + std::to_string(io->GetNumberOfComponents()) +
                      " components per voxel where a scalar CT is expected",
                  path, "give a scalar (grey-level) image");
    }
    CheckMetaImageDataSize(*io, path);
    reader->SetImageIO(io);
    reader->SetFileName(path);
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("cannot read the image: ") + e.GetDescription(), path,
                std::string("check the file is complete and one of ") + kFormats);
  }
  CtImage ct = FromItk(*reader->GetOutput(), path);
  if (dynamic_cast<itk::GDCMImageIO*>(io.GetPointer())) {
    const DicomSeries tags = ReadDicomFileTags(path);
    if (require_ct) CheckModality(tags.modality, path);
    ct.series_uid = tags.uid;
    ct.modality = tags.modality;
  }
  return ct;
}

bool IsDicomFile(const std::string& path) {
  RegisterItkImageIo();
  itk::ImageIOBase::Pointer io = itk::ImageIOFactory::CreateImageIO(path.c_str(), itk::IOFileModeEnum::ReadMode);
  return dynamic_cast<itk::GDCMImageIO*>(io.GetPointer()) != nullptr;
}

std::vector<DicomSeries> SeriesIn(const std::string& folder) {
  std::vector<DicomSeries> series = ListDicomSeries(folder);
  if (series.empty()) {
    throw Error("no DICOM series in the folder", folder,
                "give a folder of DICOM files (subfolders are not searched) or an image file");
  }
  return series;
}

// The series of a folder, or, when it holds none, those of its subfolders (a
// folder per phase, as exports and the phantom lay them out).
std::vector<DicomSeries> SeriesInOrOneBelow(const std::string& folder) {
  std::vector<DicomSeries> series = ListDicomSeries(folder);
  if (!series.empty()) return series;
  std::vector<fs::path> subfolders;
  for (const auto& entry : fs::directory_iterator(folder)) {
    if (entry.is_directory()) subfolders.push_back(entry.path());
  }
  std::sort(subfolders.begin(), subfolders.end());
  for (const fs::path& subfolder : subfolders) {
    std::vector<DicomSeries> below = ListDicomSeries(subfolder.string());
    series.insert(series.end(), below.begin(), below.end());
  }
  if (series.empty()) {
    throw Error("no DICOM series in the folder or its subfolders", folder,
                "give a folder of DICOM files, a folder of such folders, or image files");
  }
  return series;
}

void CheckExists(const std::string& path) {
  if (!fs::exists(path)) throw Error("no such file or folder", path, "check the path");
}

CtImage Read(const std::string& path, bool require_ct) {
  CheckExists(path);
  if (!fs::is_directory(path)) return ReadImageFile(path, require_ct);
  const std::vector<DicomSeries> series = SeriesIn(path);
  if (series.size() > 1) {
    throw Error("the folder holds " + std::to_string(series.size()) + " DICOM series where one is expected: " +
                    DescribeSeries(series),
                path, "give the folder of one series, or select the series by UID");
  }
  return ReadSeries(series.front(), require_ct);
}

// What one phase is read from: a DICOM series, or an image file.
struct PhaseSource {
  std::string path;
  const DicomSeries* series = nullptr;
  PhaseTags tags;
};

std::string GridText(const CtImage& ct) {
  char text[512];
  const Eigen::Matrix3d& R = ct.direction;
  std::snprintf(text, sizeof text,
                "size %dx%dx%d, spacing %.6g x %.6g x %.6g mm, origin (%.6g, %.6g, %.6g) mm, "
                "direction [%.4g %.4g %.4g; %.4g %.4g %.4g; %.4g %.4g %.4g]",
                ct.size.x(), ct.size.y(), ct.size.z(), 1e3 * ct.spacing_m.x(), 1e3 * ct.spacing_m.y(),
                1e3 * ct.spacing_m.z(), 1e3 * ct.origin_m.x(), 1e3 * ct.origin_m.y(), 1e3 * ct.origin_m.z(), R(0, 0),
                R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2));
  return text;
}

// Every phase on the first phase's grid. Tolerances: what decimal DICOM text
// and float headers round to, far below any real difference between scans.
void CheckSameGrid(const CtImage& first, const CtImage& phase, int index) {
  const double h = first.spacing_m.minCoeff();
  std::string differs;
  if (phase.size != first.size) {
    differs = "size";
  } else if (((phase.spacing_m - first.spacing_m).cwiseAbs().array() > 1e-4 * first.spacing_m.array()).any()) {
    differs = "spacing";
  } else if ((phase.direction - first.direction).cwiseAbs().maxCoeff() > 1e-4) {
    differs = "orientation";
  } else if ((phase.origin_m - first.origin_m).norm() > 0.01 * h) {
    differs = "origin";
  }
  if (differs.empty()) return;
  throw Error("the phases differ in " + differs + ": phase 0 (" + first.source +
                  ") has " + GridText(first) + "; phase " + std::to_string(index) + " (" + phase.source + ") has " +
                  GridText(phase),
              phase.source, "give the phases of one 4D CT, reconstructed on one grid");
}

void ThrowIfInvalid(const CtReadOptions& options) {
  if (const std::string wrong = options.Validate(); !wrong.empty()) {
    throw Error("invalid CT reading options: " + wrong, "the CT reading options",
                "give each phase's series UID once, and a finite, non-zero intensity slope");
  }
}

// A CT as read, its intensities taken as the options say, on S's axes.
CtImage AsCt(CtImage ct, const CtReadOptions& options) {
  if (options.intensity == CtIntensity::kScale) {
    for (float& v : ct.values) {
      v = static_cast<float>(options.intensity_slope * v + options.intensity_intercept);
    }
  }
  float outside = -1024;
  if (options.intensity == CtIntensity::kNotHu) {
    ct.values_are_hu = false;
    // Nothing is known of these values: beyond the scan, the darkest there is.
    if (!ct.values.empty()) outside = *std::min_element(ct.values.begin(), ct.values.end());
  } else {
    CheckHounsfield(ct);
  }
  return OnAxisAlignedGrid(std::move(ct), Interpolation::kLinear, outside);
}

std::string Hu(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", value);
  return text;
}

}  // namespace

void CheckHounsfield(const CtImage& ct) {
  if (ct.values.empty()) return;
  // Counts of whole HU from -200 up; the median of the body from them, without a copy of the image.
  constexpr double kAirBelow = -200, kMinimumAirFraction = 0.001, kTissueLow = -150, kTissueHigh = 500;
  constexpr int kBins = 33000;  // whole HU from -200 past int16's range; above counts in the last
  std::vector<size_t> counts(kBins, 0);
  size_t below = 0, above = 0;
  float low = ct.values.front(), high = ct.values.front();
  for (float v : ct.values) {
    if (std::isnan(v)) continue;
    low = std::min(low, v);
    high = std::max(high, v);
    if (v < kAirBelow) {
      ++below;
    } else {
      ++above;
      ++counts[static_cast<size_t>(std::min<double>(kBins - 1, v - kAirBelow))];
    }
  }
  double median = NAN;
  for (size_t bin = 0, seen = 0; above > 0 && bin < counts.size(); ++bin) {
    seen += counts[bin];
    if (2 * seen >= above) {
      median = kAirBelow + bin;  // to the whole HU below
      break;
    }
  }
  const double air_fraction = static_cast<double>(below) / ct.values.size();
  const bool no_air = air_fraction < kMinimumAirFraction;
  const bool no_tissue = above > 0 && (median < kTissueLow || median > kTissueHigh);
  if (!no_air && !no_tissue) return;

  char figures[256];
  std::snprintf(figures, sizeof figures,
                "values %s..%s, %.3g%% of voxels below -200 HU (a CT has air, lung or fat: at least 0.1%%), "
                "median above -200 HU %s (a CT's soft tissue: -150..500 HU)",
                Hu(low).c_str(), Hu(high).c_str(), 100 * air_fraction, std::isnan(median) ? "none" : Hu(median).c_str());
  std::string what = std::string("the values do not look like a CT in Hounsfield units: ") + figures;
  if (low >= 0 && high <= 255) what += "; 0..255 is what an 8-bit image holds";
  if (!ct.modality.empty()) what += "; DICOM modality " + ct.modality;
  throw Error(what, ct.source,
              "give a CT in Hounsfield units; or, if its values are HU after a linear rescale, give it with "
              "--intensity-scale SLOPE,INTERCEPT (HU = SLOPE * value + INTERCEPT); or take it as it is with --not-hu "
              "(then give a label map: automatic segmentation needs HU)");
}

CtImage ReadCtImage(const std::string& path, const CtReadOptions& options) {
  ThrowIfInvalid(options);
  return AsCt(Read(path, /*require_ct=*/true), options);
}

CtImage ReadLabelMap(const std::string& path) {
  CtImage labels = Read(path, /*require_ct=*/false);
  labels.values_are_hu = false;
  return OnAxisAlignedGrid(std::move(labels), Interpolation::kNearest, 0);
}

std::string CtReadOptions::Validate() const {
  std::set<std::string> seen;
  for (const std::string& uid : series_uids) {
    if (uid.empty()) return "a series UID is empty";
    if (!seen.insert(uid).second) return "series UID " + uid + " is given twice";
  }
  if (intensity == CtIntensity::kScale && (!std::isfinite(intensity_slope) || intensity_slope == 0 ||
                                           !std::isfinite(intensity_intercept))) {
    return "the intensity scale (slope " + Hu(intensity_slope) + ", intercept " + Hu(intensity_intercept) +
           ") must be finite with a non-zero slope";
  }
  return {};
}

std::vector<CtImage> ReadCtPhases(const std::vector<std::string>& inputs, const CtReadOptions& options) {
  ThrowIfInvalid(options);
  if (inputs.empty()) {
    throw Error("no CT given", "the CT inputs",
                "give one folder holding every phase, one folder per phase, or one file per phase");
  }
  for (const std::string& input : inputs) CheckExists(input);
  const std::string where = inputs.size() == 1 ? inputs.front() : inputs.front() + " .. " + inputs.back();

  // Every series of the input folders, kept here while the phases point into it.
  std::vector<std::vector<DicomSeries>> folders;
  folders.reserve(inputs.size());
  std::vector<PhaseSource> sources;
  bool given_order = true;
  if (!options.series_uids.empty()) {
    std::vector<DicomSeries> all;
    for (const std::string& input : inputs) {
      if (!fs::is_directory(input)) {
        throw Error("series UIDs select series in folders, and this is a file", input,
                    "give the folders that hold the series, or the files without series UIDs");
      }
      folders.push_back(ListDicomSeries(input));
      all.insert(all.end(), folders.back().begin(), folders.back().end());
    }
    for (const std::string& uid : options.series_uids) {
      const DicomSeries* found = nullptr;
      for (const auto& folder : folders) {
        for (const DicomSeries& series : folder) {
          if (series.uid == uid) found = &series;
        }
      }
      if (!found) {
        throw Error("series UID " + uid + " is in none of the inputs, which hold: " +
                        (all.empty() ? std::string("no DICOM series") : DescribeSeries(all)),
                    where, "give UIDs of the series listed");
      }
      sources.push_back({found->folder, found, found->tags});
    }
  } else if (inputs.size() == 1 && fs::is_directory(inputs.front())) {
    folders.push_back(SeriesInOrOneBelow(inputs.front()));
    for (const DicomSeries& series : folders.back()) sources.push_back({series.folder, &series, series.tags});
    given_order = false;
  } else {
    for (const std::string& input : inputs) {
      if (!fs::is_directory(input)) {
        PhaseTags tags;
        tags.where = input;
        tags.name_percentage = NamePercentage(input);
        if (IsDicomFile(input)) tags = ReadDicomFileTags(input).tags;
        sources.push_back({input, nullptr, tags});
        continue;
      }
      folders.push_back(SeriesIn(input));
      if (folders.back().size() > 1) {
        throw Error("the folder holds " + std::to_string(folders.back().size()) +
                        " DICOM series where one phase is expected: " + DescribeSeries(folders.back()),
                    input, "give one folder per phase, or one folder of every phase, or select the series by UID");
      }
      sources.push_back({input, &folders.back().front(), folders.back().front().tags});
    }
  }

  std::vector<PhaseTags> tags;
  for (const PhaseSource& source : sources) tags.push_back(source.tags);
  // Phases chosen by UID are what the user wants, whole cycle or not.
  const PhaseOrder order = OrderPhases(tags, given_order, options.series_uids.empty(), where);

  std::vector<CtImage> phases;
  const int count = static_cast<int>(order.order.size());
  for (int p = 0; p < count; ++p) {
    const PhaseSource& source = sources[order.order[p]];
    CtImage phase = AsCt(source.series ? ReadSeries(*source.series, /*require_ct=*/true)
                                       : ReadImageFile(source.path, /*require_ct=*/true),
                         options);
    phase.cycle_fraction = order.cycle_fraction[p];
    if (!phases.empty()) CheckSameGrid(phases.front(), phase, p);
    if (options.progress) {
      options.progress(phase, p, count);
    } else {
      Logger("io").info("CT phase {}/{}: {} ({}x{}x{}{})", p + 1, count, phase.source, phase.size.x(),
                        phase.size.y(), phase.size.z(),
                        std::isnan(phase.cycle_fraction)
                            ? std::string()
                            : ", " + std::to_string(static_cast<int>(std::lround(100 * phase.cycle_fraction))) + "%");
    }
    phases.push_back(std::move(phase));
  }
  return phases;
}

}  // namespace dg::io
