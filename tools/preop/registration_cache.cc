#include "tools/preop/registration_cache.h"

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <mutex>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "io/h5_file.h"
#include "sim/error.h"
#include "sim/log.h"

namespace dg::tools::preop {
namespace {

// HDF5 as Debian builds it is not thread-safe: one file operation at a time.
std::mutex h5_mutex;

// FNV-1a over the image's geometry and values: equal images hash equal, and
// an edited voxel changes the hash.
std::string HashOf(const io::CtImage& image) {
  std::uint64_t hash = 1469598103934665603ull;
  const auto mix = [&](const void* data, std::size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < bytes; ++i) hash = (hash ^ p[i]) * 1099511628211ull;
  };
  mix(image.size.data(), sizeof(int) * 3);
  mix(image.spacing_m.data(), sizeof(double) * 3);
  mix(image.origin_m.data(), sizeof(double) * 3);
  mix(image.direction.data(), sizeof(double) * 9);
  mix(image.values.data(), sizeof(float) * image.values.size());
  return fmt::format("{:016x}", hash);
}

std::string OptionsText(const stages::preop::MotionRegistrationOptions& o, const io::CtImage& grid) {
  return fmt::format("grid {:.17g} mm, levels {}, iterations {}, metric {}, bending {:.17g}, samples {:.17g} mm, "
                     "on {} voxels from ({:.17g}, {:.17g}, {:.17g}) m",
                     o.grid_spacing_mm, o.levels, o.max_iterations, static_cast<int>(o.metric), o.bending_weight,
                     o.finest_sample_mm, fmt::join(grid.size, " x "), grid.origin_m.x(), grid.origin_m.y(),
                     grid.origin_m.z());
}

}  // namespace

RegistrationCache::RegistrationCache(std::string folder, const std::vector<io::CtImage>& phases,
                                     const stages::preop::MotionRegistrationOptions& options)
    : folder_(std::move(folder)),
      grid_(stages::preop::RegistrationGrid(phases.at(0), options)),
      options_text_(OptionsText(options, grid_)) {
  std::filesystem::create_directories(folder_);
  for (const io::CtImage& phase : phases) phase_hashes_.push_back(HashOf(phase));
}

std::string RegistrationCache::PathOf(int k) const { return fmt::format("{}/phase_{:02d}.h5", folder_, k); }

std::string RegistrationCache::KeyOf(int k) const {
  return fmt::format("phase 0 {}, phase {} {}; {}", phase_hashes_[0], k, phase_hashes_[k], options_text_);
}

std::optional<stages::preop::PhaseDeformation> RegistrationCache::Load(int k) const {
  const std::string path = PathOf(k);
  if (!std::filesystem::exists(path)) return std::nullopt;
  std::lock_guard lock(h5_mutex);
  try {
    const io::H5Reader file(path);
    if (file.ReadAttribute<std::string>("/", "key") != KeyOf(k)) {
      Logger("tools").info("phase {}: the cached registration was made from other inputs; registering again", k);
      return std::nullopt;
    }
    stages::preop::PhaseRegistrationReport report;
    report.phase = k;
    report.metric_before = file.ReadAttribute<double>("/", "metric_before");
    report.metric_after = file.ReadAttribute<double>("/", "metric_after");
    report.iterations = static_cast<int>(file.ReadAttribute<std::int64_t>("/", "iterations"));
    report.evaluations = static_cast<int>(file.ReadAttribute<std::int64_t>("/", "evaluations"));
    report.min_jacobian = file.ReadAttribute<double>("/", "min_jacobian");
    report.max_jacobian = file.ReadAttribute<double>("/", "max_jacobian");
    report.wall_s = file.ReadAttribute<double>("/", "wall_s");
    report.stop_condition = "cached in " + path;
    return stages::preop::PhaseDeformation::FromParameters(file.Read<double>("/fixed_parameters"),
                                                          file.Read<double>("/parameters"), grid_, report);
  } catch (const Error& e) {
    Logger("tools").warn("phase {}: the cached registration does not read ({}); registering again", k, e.what());
    return std::nullopt;
  }
}

void RegistrationCache::Save(int k, const stages::preop::PhaseDeformation& deformation) const {
  const std::vector<double> fixed = deformation.FixedParameters(), parameters = deformation.Parameters();
  const stages::preop::PhaseRegistrationReport& report = deformation.report();
  const std::string path = PathOf(k), partial = path + ".partial";
  std::lock_guard lock(h5_mutex);
  {
    io::H5Writer file(partial);
    file.Write("/fixed_parameters", fixed.data(), {fixed.size()});
    file.Write("/parameters", parameters.data(), {parameters.size()});
    file.WriteAttribute("/", "key", KeyOf(k));
    file.WriteAttribute("/", "metric_before", report.metric_before);
    file.WriteAttribute("/", "metric_after", report.metric_after);
    file.WriteAttribute("/", "iterations", report.iterations);
    file.WriteAttribute("/", "evaluations", report.evaluations);
    file.WriteAttribute("/", "min_jacobian", report.min_jacobian);
    file.WriteAttribute("/", "max_jacobian", report.max_jacobian);
    file.WriteAttribute("/", "wall_s", report.wall_s);
  }
  // Renamed when whole: a run stopped while writing leaves no entry that looks complete.
  std::filesystem::rename(partial, path);
}

}  // namespace dg::tools::preop
