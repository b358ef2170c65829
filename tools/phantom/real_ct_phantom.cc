#include "tools/phantom/real_ct_phantom.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <random>
#include <vector>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "io/ct/ct_reader.h"
#include "io/ct/dicom_writer.h"
#include "io/ct/displacement_field.h"
#include "sim/cubic_bspline.h"
#include "sim/error.h"
#include "tools/json_text.h"
#include "tools/phantom/ct_export.h"
#include "tools/phantom/real_ct_image_file.h"

namespace dg::tools::phantom {
namespace {

namespace fs = std::filesystem;
using Kind = RealCtMotion::Kind;

constexpr double kPi = 3.14159265358979323846;
// Refused below: the brief's bound, far from folding (0) and from the
// fixed-point inversion's limit.
constexpr double kMinJacobianDeterminant = 0.5;
constexpr double kMaxGradientNorm = 0.9;
// Without a label map the motion centres on the body: voxels of at least this
// many HU (soft tissue and bone, not air or lung).
constexpr double kBodyHu = -500;
// The window is at least this wide, so that a few millimetres of motion stay
// well inside the Jacobian's bound on small organs (docs/commands/phantom.md).
constexpr double kMinWindow_m = 0.04;
// The respiratory window is wider than the organ: the organ mostly translates.
constexpr double kRespiratoryWindowFactor = 1.5;

// The region the motion is centred on: its centroid, volume and principal axis.
struct Region {
  Eigen::Vector3d centroid_S_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d principal_axis_S = Eigen::Vector3d::UnitZ();
  double volume_m3 = 0;
  std::size_t voxels = 0;

  double EquivalentRadius_m() const { return std::cbrt(3 * volume_m3 / (4 * kPi)); }
};

void Progress(bool progress, const std::string& line) {
  if (progress) std::fprintf(stderr, "phantom: %s\n", line.c_str());
}

std::string Vector3Text(const Eigen::Vector3d& v, double scale, const char* unit) {
  char text[96];
  std::snprintf(text, sizeof text, "(%.6g, %.6g, %.6g) %s", scale * v.x(), scale * v.y(), scale * v.z(), unit);
  return text;
}

std::string GridText(const io::CtImage& image) {
  char text[256];
  std::snprintf(text, sizeof text, "%d x %d x %d voxels of %.6g x %.6g x %.6g mm at ", image.size.x(), image.size.y(),
                image.size.z(), 1e3 * image.spacing_m.x(), 1e3 * image.spacing_m.y(), 1e3 * image.spacing_m.z());
  return text + Vector3Text(image.origin_m, 1e3, "mm");
}

// The label map must lie on the CT's grid, to what decimal headers round to
// (as the phases of a 4D CT, docs/preop.md).
void RequireSameGrid(const io::CtImage& ct, const io::CtImage& labels) {
  const double spacing = ct.spacing_m.minCoeff();
  const bool same = labels.size == ct.size && (labels.spacing_m - ct.spacing_m).cwiseAbs().maxCoeff() <= 1e-4 * spacing &&
                    (labels.origin_m - ct.origin_m).norm() <= 1e-2 * spacing &&
                    (labels.direction - ct.direction).cwiseAbs().maxCoeff() <= 1e-4;
  if (!same) {
    throw Error("the label map is not on the CT's grid: CT " + GridText(ct) + ", labels " + GridText(labels),
                labels.source, "give the label map segmented on this CT (the same size, spacing, origin and direction)");
  }
}

// The same voxels on a right-handed grid: DICOM's slice axis is the
// orientation's normal, so a left-handed grid would come back from the DICOM
// series with its slices reversed.
void MakeRightHanded(io::CtImage* image) {
  if (image->direction.determinant() > 0) return;
  const Eigen::Vector3i n = image->size;
  std::vector<float> reversed(image->values.size());
  for (int k = 0; k < n.z(); ++k) {
    std::copy_n(image->values.begin() + image->Index(0, 0, n.z() - 1 - k), std::size_t(n.x()) * n.y(),
                reversed.begin() + image->Index(0, 0, k));
  }
  image->origin_m = image->PointOf(0, 0, n.z() - 1);
  image->direction.col(2) = -image->direction.col(2);
  image->values = std::move(reversed);
}

// Centroid, volume and principal axis of the voxels `inside` holds for.
template <typename Inside>
Region RegionOf(const io::CtImage& grid, const Inside& inside) {
  Region region;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (int k = 0; k < grid.size.z(); ++k) {
    for (int j = 0; j < grid.size.y(); ++j) {
      for (int i = 0; i < grid.size.x(); ++i) {
        if (!inside(grid.Index(i, j, k))) continue;
        const Eigen::Vector3d X = grid.PointOf(i, j, k);
        sum += X;
        second += X * X.transpose();
        ++region.voxels;
      }
    }
  }
  if (region.voxels == 0) return region;
  region.centroid_S_m = sum / double(region.voxels);
  const Eigen::Matrix3d covariance =
      second / double(region.voxels) - region.centroid_S_m * region.centroid_S_m.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance);
  Eigen::Vector3d axis = eigen.eigenvectors().col(2);  // the largest eigenvalue's
  Eigen::Index largest;
  axis.cwiseAbs().maxCoeff(&largest);
  if (axis[largest] < 0) axis = -axis;  // a sign that does not depend on the solver
  region.principal_axis_S = axis;
  region.volume_m3 = double(region.voxels) * grid.spacing_m.prod();
  return region;
}

// The motion: centred on the organ (or the body), its window the organ's
// equivalent radius (half the body's), its shape drawn from the seed.
RealCtMotion::Parameters MotionParameters(const RealCtPhantomOptions& options, const Region& region, bool labelled) {
  std::mt19937_64 random(options.seed);
  std::uniform_real_distribution<double> unit(0, 1);
  RealCtMotion::Parameters parameters;
  parameters.kind = options.motion;
  parameters.centre_S_m = region.centroid_S_m;
  parameters.axis_S = labelled ? region.principal_axis_S : Eigen::Vector3d::UnitZ();
  const double radius = labelled ? region.EquivalentRadius_m() : region.EquivalentRadius_m() / 2;
  parameters.window_m = std::max(radius, kMinWindow_m);
  if (options.motion == Kind::kRespiratory) parameters.window_m *= kRespiratoryWindowFactor;
  parameters.amplitude_m = 1e-3 * options.amplitude_mm;
  parameters.twist = 0.3 + 0.4 * unit(random);
  parameters.shortening = 0.3 + 0.3 * unit(random);
  parameters.expansion = 0.2 + 0.2 * unit(random);
  return parameters;
}

double CycleFraction(int phase, int phases) { return double(phase) / phases; }

// Refuses a motion that is not safely invertible at any phase, before any file is written.
double RequireInvertible(const RealCtMotion& motion, const RealCtPhantomOptions& options) {
  double min_determinant = 1;
  for (int k = 1; k < options.phases; ++k) {
    const RealCtMotion::JacobianBounds bounds = motion.Jacobian(CycleFraction(k, options.phases));
    min_determinant = std::min(min_determinant, bounds.min_determinant);
    if (bounds.min_determinant <= kMinJacobianDeterminant || bounds.max_gradient_norm >= kMaxGradientNorm) {
      char what[256];
      std::snprintf(what, sizeof what,
                    "the %s motion of %.4g mm in a window of %.4g mm is not safely invertible at phase %d: its "
                    "Jacobian determinant falls to %.3f (at least %.2f needed), |grad u| reaches %.3f (below %.2f needed)",
                    RealCtMotion::KindName(options.motion), options.amplitude_mm, 1e3 * motion.parameters().window_m,
                    k, bounds.min_determinant, kMinJacobianDeterminant, bounds.max_gradient_norm, kMaxGradientNorm);
      throw Error(what, options.ct,
                  "lower --amplitude-mm (the determinant's distance from 1 grows about linearly with it), or label a "
                  "larger region with --labels / --organ-label (the window follows its size)");
    }
  }
  return min_determinant;
}

// Each phase as a scanner reconstructs it, every phase alike: the object is
// the source CT's cubic B-spline, seen through a Gaussian point-spread function
// of kPointSpread_voxels along each axis, I_k(x) = (G * O)(X) with X + u_k(X) = x.
// The motion is smooth on the scale of the PSF, so the blur is applied to the
// source once. Phase 0 samples the blurred source at its own voxels, the
// others at sub-voxel positions: a spline through band-limited data resamples
// it with little loss, so no phase is sharper than another (resampling only
// the moving phases, trilinearly, blurs each by an amount that follows its
// sub-voxel shift, and biases a registration to the sharp phase 0 by a third
// of a 0.7 mm motion on a 3 mm CT; docs/commands/phantom.md).
constexpr double kPointSpread_voxels = 0.5;
// The cubic B-spline's prefilter: its pole, and the samples its causal
// initialisation sums (the pole's power falls below 1e-10 by then).
const double kSplinePole = std::sqrt(3.0) - 2;
constexpr int kPrefilterHorizon = 18;

// Applies `filter` to every line of `values` (laid out as `image`) along `axis`.
template <typename Filter>
void ForEachLine(const io::CtImage& image, int axis, std::vector<double>* values, const Filter& filter) {
  const Eigen::Vector3i n = image.size;
  const int a = (axis + 1) % 3, b = (axis + 2) % 3;
  const std::size_t stride = axis == 0 ? 1 : axis == 1 ? std::size_t(n.x()) : std::size_t(n.x()) * n.y();
  tbb::parallel_for(tbb::blocked_range<int>(0, n[b]), [&](const tbb::blocked_range<int>& range) {
    std::vector<double> line(n[axis]);
    for (int q = range.begin(); q != range.end(); ++q) {
      for (int p = 0; p < n[a]; ++p) {
        Eigen::Vector3i at = Eigen::Vector3i::Zero();
        at[a] = p;
        at[b] = q;
        const std::size_t first = image.Index(at.x(), at.y(), at.z());
        for (int i = 0; i < n[axis]; ++i) line[i] = (*values)[first + i * stride];
        filter(&line);
        for (int i = 0; i < n[axis]; ++i) (*values)[first + i * stride] = line[i];
      }
    }
  });
}

// The source seen through the point-spread function (edge voxels repeated).
std::vector<double> PointSpread(const io::CtImage& source) {
  std::vector<double> values(source.values.begin(), source.values.end());
  const int radius = static_cast<int>(std::ceil(3 * kPointSpread_voxels));
  std::vector<double> kernel(2 * radius + 1);
  for (int i = -radius; i <= radius; ++i) {
    kernel[i + radius] = std::exp(-0.5 * i * i / (kPointSpread_voxels * kPointSpread_voxels));
  }
  const double total = std::accumulate(kernel.begin(), kernel.end(), 0.0);
  for (double& weight : kernel) weight /= total;
  for (int axis = 0; axis < 3; ++axis) {
    ForEachLine(source, axis, &values, [&](std::vector<double>* line) {
      const std::vector<double> in = *line;
      const int last = static_cast<int>(in.size()) - 1;
      for (int i = 0; i <= last; ++i) {
        double sum = 0;
        for (int j = -radius; j <= radius; ++j) sum += kernel[j + radius] * in[std::clamp(i + j, 0, last)];
        (*line)[i] = sum;
      }
    });
  }
  return values;
}

// Interpolating cubic B-spline coefficients of `values` on `grid`, mirror
// boundaries (Unser's recursive prefilter, as ITK's BSplineDecompositionImageFilter).
std::vector<double> SplineCoefficients(const io::CtImage& grid, std::vector<double> values) {
  const double z = kSplinePole, gain = (1 - z) * (1 - 1 / z);
  for (int axis = 0; axis < 3; ++axis) {
    if (grid.size[axis] < 2) continue;
    ForEachLine(grid, axis, &values, [&](std::vector<double>* line) {
      std::vector<double>& c = *line;
      const int n = static_cast<int>(c.size());
      for (double& v : c) v *= gain;
      double sum = c[0], power = z;
      for (int i = 1; i < std::min(n, kPrefilterHorizon); ++i, power *= z) sum += power * c[i];
      c[0] = sum;
      for (int i = 1; i < n; ++i) c[i] += z * c[i - 1];
      c[n - 1] = z / (z * z - 1) * (z * c[n - 2] + c[n - 1]);
      for (int i = n - 2; i >= 0; --i) c[i] = z * (c[i + 1] - c[i]);
    });
  }
  return values;
}

// Index i mirrored into [0, n - 1] about the end samples.
int Mirrored(int i, int n) {
  if (n == 1) return 0;
  while (i < 0 || i > n - 1) i = i < 0 ? -i : 2 * (n - 1) - i;
  return i;
}

// The spline of `coefficients` at continuous index c (clamped to the grid:
// the edge voxels' values repeated outside it).
double SplineAt(const io::CtImage& grid, const std::vector<double>& coefficients, const Eigen::Vector3d& c) {
  int first[3];
  double w[3][4];
  for (int a = 0; a < 3; ++a) {
    const double clamped = std::clamp(c[a], 0.0, double(grid.size[a] - 1));
    const double floor = std::floor(clamped);
    first[a] = static_cast<int>(floor) - 1;
    sim::CubicBSplineWeights(clamped - floor, w[a]);
  }
  double value = 0;
  for (int k = 0; k < 4; ++k) {
    const int z = Mirrored(first[2] + k, grid.size.z());
    for (int j = 0; j < 4; ++j) {
      const int y = Mirrored(first[1] + j, grid.size.y());
      double row = 0;
      for (int i = 0; i < 4; ++i) row += w[0][i] * coefficients[grid.Index(Mirrored(first[0] + i, grid.size.x()), y, z)];
      value += w[2][k] * w[1][j] * row;
    }
  }
  return value;
}

// Phase k from the spline coefficients of the blurred source: I_k(x) = spline(X), X + u_k(X) = x.
io::CtImage WarpedPhase(const io::CtImage& source, const std::vector<double>& coefficients, const RealCtMotion& motion,
                        double cycle_fraction) {
  io::CtImage phase = source;
  const Eigen::Matrix3d to_voxel = (source.direction * source.spacing_m.asDiagonal()).inverse();
  tbb::parallel_for(tbb::blocked_range<int>(0, source.size.z()), [&](const tbb::blocked_range<int>& slices) {
    for (int k = slices.begin(); k != slices.end(); ++k) {
      for (int j = 0; j < source.size.y(); ++j) {
        for (int i = 0; i < source.size.x(); ++i) {
          const Eigen::Vector3d x = source.PointOf(i, j, k);
          const Eigen::Vector3d X = motion.Activation(cycle_fraction) == 0 ? x : motion.Undeform(x, cycle_fraction);
          phase.values[phase.Index(i, j, k)] = static_cast<float>(SplineAt(source, coefficients, to_voxel * (X - source.origin_m)));
        }
      }
    }
  });
  return phase;
}

// The truth: u_k(X) at every grid point, mm.
io::DisplacementField TruthField(const io::CtImage& grid, const RealCtMotion& motion, double cycle_fraction) {
  io::DisplacementField field = io::ZeroFieldOn(grid);
  tbb::parallel_for(tbb::blocked_range<int>(0, grid.size.z()), [&](const tbb::blocked_range<int>& slices) {
    for (int k = slices.begin(); k != slices.end(); ++k) {
      for (int j = 0; j < grid.size.y(); ++j) {
        for (int i = 0; i < grid.size.x(); ++i) {
          field.u_mm.col(static_cast<Eigen::Index>(field.Index(i, j, k))) =
              (1e3 * motion.Displacement(grid.PointOf(i, j, k), cycle_fraction)).cast<float>();
        }
      }
    }
  });
  return field;
}

// What makes one warped CT differ from another: its UIDs derive from it.
std::string Identity(const RealCtPhantomOptions& options) {
  char text[256];
  std::snprintf(text, sizeof text, ": %s motion, %.9g mm, %d phases, period %.9g s, seed %llu, organ label %d",
                RealCtMotion::KindName(options.motion), options.amplitude_mm, options.phases, options.Period_s(),
                static_cast<unsigned long long>(options.seed), options.organ_label);
  return "dynaguide phantom from the real CT " + fs::absolute(options.ct).string() + " labels " + options.labels + text;
}

void WriteDicomPhase(const io::CtImage& phase_image, const RealCtPhantomOptions& options, int phase,
                     const std::string& folder) {
  io::DicomSeriesInfo info =
      PhaseSeriesInfo(Identity(options), phase, options.phases,
                      options.motion == Kind::kCardiac ? std::optional(60 / options.Period_s()) : std::nullopt);
  info.patient_id = "DG-REAL-CT-" + std::to_string(options.seed);
  info.patient_name = "Phantom^RealCt";
  info.study_description = std::string("dynaguide warped real CT, ") + RealCtMotion::KindName(options.motion);
  io::WriteDicomSeries(phase_image, folder, info);
}

std::string PhaseName(const char* pattern, int phase) {
  char name[64];
  std::snprintf(name, sizeof name, pattern, phase);
  return name;
}

double MaxNorm(const io::DisplacementField& field) {
  return field.u_mm.size() == 0 ? 0.0 : double(field.u_mm.colwise().norm().maxCoeff());
}

void WriteReport(const RealCtPhantomOptions& options, const RealCtMotion& motion, const Region& region,
                 const RealCtPhantomSummary& summary) {
  const RealCtMotion::Parameters& p = motion.parameters();
  nlohmann::ordered_json json;
  json["what"] = "a real CT warped by a known smooth motion (dynaguide phantom --ct): not a synthetic phantom";
  json["source_ct"] = fs::absolute(options.ct).string();
  json["source_labels"] = options.labels.empty() ? nlohmann::ordered_json() : nlohmann::ordered_json(fs::absolute(options.labels).string());
  json["organ_label"] = options.organ_label;
  json["size"] = {summary.size.x(), summary.size.y(), summary.size.z()};
  json["motion"] = RealCtMotion::KindName(options.motion);
  json["amplitude_mm"] = options.amplitude_mm;
  json["phases"] = options.phases;
  json["period_s"] = options.Period_s();
  json["seed"] = options.seed;
  json["centre_S_mm"] = {1e3 * p.centre_S_m.x(), 1e3 * p.centre_S_m.y(), 1e3 * p.centre_S_m.z()};
  json["centred_on"] = options.labels.empty() ? "the body (voxels of at least -500 HU)" : "the labelled organ";
  json["region_volume_ml"] = Significant(1e6 * region.volume_m3, 6);
  json["window_mm"] = Significant(1e3 * p.window_m, 6);
  if (options.motion == Kind::kCardiac) {
    json["axis_S"] = {p.axis_S.x(), p.axis_S.y(), p.axis_S.z()};
    json["twist"] = p.twist;
    json["shortening"] = p.shortening;
  } else {
    json["expansion"] = p.expansion;
  }
  json["activation"] = options.motion == Kind::kCardiac ? "sin^2(pi phase)" : "sin^4(pi phase)";
  json["phase_cycle_fraction"] = "phase k of N at k / N";
  json["max_displacement_mm"] = Significant(summary.max_displacement_mm, 6);
  json["min_jacobian_determinant"] = Significant(summary.min_jacobian, 6);
  json["image_formation"] =
      "every phase alike: the source's cubic B-spline through a Gaussian point-spread function; edge voxels repeated "
      "outside the grid";
  json["point_spread_sigma_voxels"] = kPointSpread_voxels;
  json["truth"] = "truth/dvf_phase_NN.mha: u(X) in mm, X of phase 0 at X + u(X) in phase NN";
  json["ct_format"] = options.ct_format;
  json["labels"] = summary.labels_file.empty() ? nlohmann::ordered_json() : nlohmann::ordered_json("labels.nii.gz");
  const std::string path = options.out_dir + "/phantom.json";
  std::ofstream file(path);
  file << JsonText(json);
  if (!file) throw Error("cannot write the report", path, "check the folder is writable and has space");
}

}  // namespace

std::string RealCtPhantomOptions::Validate() const {
  if (ct.empty()) return "--ct is empty";
  if (out_dir.empty()) return "--out is empty";
  if (phases < 2 || phases > 100) return "--phases must lie in 2..100 (phase_NN names)";
  if (!(amplitude_mm > 0) || !std::isfinite(amplitude_mm)) return "--amplitude-mm must be positive";
  if (!(period_s >= 0) || !std::isfinite(period_s)) return "--period-s must not be negative";
  if (organ_label < 0) return "--organ-label must not be negative";
  if (organ_label > 0 && labels.empty()) return "--organ-label needs --labels";
  if (ct_format != "mhd" && ct_format != "dicom" && ct_format != "both") return "--ct-format must be mhd, dicom or both";
  return {};
}

double RealCtPhantomOptions::Period_s() const {
  if (period_s > 0) return period_s;
  return motion == RealCtMotion::Kind::kCardiac ? 1.0 : 4.0;
}

std::string RealCtPhantomSummary::Describe() const {
  char text[1024];
  std::snprintf(text, sizeof text,
                "4D CT: %s/ct (%d phases of %d x %d x %d voxels), warped from a real CT\n"
                "motion: window %.4g mm centred at (%.6g, %.6g, %.6g) mm; max |u| %.4g mm, min Jacobian determinant "
                "%.4f\n"
                "truth: %s/truth/dvf_phase_NN.mha\n"
                "%s%s%s"
                "wall: %.1f s\n",
                out_dir.c_str(), phases, size.x(), size.y(), size.z(), window_mm, centre_S_mm.x(), centre_S_mm.y(),
                centre_S_mm.z(), max_displacement_mm, min_jacobian, out_dir.c_str(),
                labels_file.empty() ? "" : "labels: ", labels_file.c_str(), labels_file.empty() ? "" : "\n", wall_s);
  return text;
}

RealCtPhantomSummary GenerateRealCtPhantom(const RealCtPhantomOptions& options) {
  if (const std::string wrong = options.Validate(); !wrong.empty()) {
    throw Error("invalid options: " + wrong, "dynaguide phantom --ct", "correct the option");
  }
  const auto start = std::chrono::steady_clock::now();
  Progress(options.progress, "reading " + options.ct);
  io::CtImage ct = io::ReadCtImage(options.ct);
  io::CtImage labels;
  const bool labelled = !options.labels.empty();
  if (labelled) {
    labels = io::ReadLabelMap(options.labels);
    RequireSameGrid(ct, labels);
    MakeRightHanded(&labels);
  }
  MakeRightHanded(&ct);

  const Region region =
      labelled ? RegionOf(ct, [&](std::size_t v) {
        return options.organ_label == 0 ? labels.values[v] != 0 : labels.values[v] == float(options.organ_label);
      })
               : RegionOf(ct, [&](std::size_t v) { return ct.values[v] >= kBodyHu; });
  if (region.voxels == 0) {
    throw Error(labelled ? "the label map has no voxel of label " + std::to_string(options.organ_label) +
                               (options.organ_label == 0 ? " (none that is not 0)" : "")
                         : "the CT has no voxel of at least -500 HU: no body to centre the motion on",
                labelled ? options.labels : options.ct,
                labelled ? "give --organ-label a label the map holds" : "give a CT in HU");
  }
  const RealCtMotion motion(MotionParameters(options, region, labelled));
  RealCtPhantomSummary summary;
  summary.out_dir = options.out_dir;
  summary.size = ct.size;
  summary.phases = options.phases;
  summary.window_mm = 1e3 * motion.parameters().window_m;
  summary.centre_S_mm = 1e3 * motion.parameters().centre_S_m;
  summary.min_jacobian = RequireInvertible(motion, options);

  const bool dicom = options.ct_format != "mhd", metaimage = options.ct_format != "dicom";
  for (const char* sub : {"/ct", "/truth"}) fs::create_directories(options.out_dir + sub);
  const std::vector<double> coefficients = SplineCoefficients(ct, PointSpread(ct));
  for (int k = 0; k < options.phases; ++k) {
    const double fraction = CycleFraction(k, options.phases);
    const io::CtImage phase = WarpedPhase(ct, coefficients, motion, fraction);
    if (dicom) WriteDicomPhase(phase, options, k, options.out_dir + PhaseName("/ct/dicom/phase_%02d", k));
    if (metaimage) WriteCtImageFile(phase, options.out_dir + PhaseName("/ct/phase_%02d.mhd", k));
    const io::DisplacementField truth = TruthField(ct, motion, fraction);
    // Uncompressed: a smooth field of floats barely compresses (433 of 472 MB on a 512 x 512 x 150 grid) and
    // zlib took 20 s of each phase's 30.
    io::WriteDisplacementField(options.out_dir + PhaseName("/truth/dvf_phase_%02d.mha", k), truth, false);
    const double max_mm = MaxNorm(truth);
    summary.max_displacement_mm = std::max(summary.max_displacement_mm, max_mm);
    char line[128];
    std::snprintf(line, sizeof line, "phase %02d of %d (%.4g%%): max |u| %.3f mm", k, options.phases, 100 * fraction,
                  max_mm);
    Progress(options.progress, line);
  }
  if (labelled) {
    summary.labels_file = options.out_dir + "/labels.nii.gz";
    WriteLabelMapFile(labels, summary.labels_file);
  }
  summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  WriteReport(options, motion, region, summary);
  return summary;
}

}  // namespace dg::tools::phantom
