// `dynaguide phantom --ct`: a real CT warped by a known motion into a 4D CT
// (docs/commands/phantom.md, "A phantom from a real CT"). The integration
// cases run the built binary on the real 3 mm abdominal CT of
// shared/data/real/03_ct_abdomen_totalseg (README.txt there: TotalSegmentator's
// test data, commit 0e65a448, example_ct_sm.nii.gz -> ct_abdomen_3mm_30slices.nii.gz,
// a Siemens Biograph40 mCT body CT resampled to 3 mm, 122 x 101 x 30, with its
// TotalSegmentator label map example_seg.nii.gz -> labels_totalseg_for_30slices.nii.gz)
// and check the phases it wrote against the truth it wrote, independently:
// phase 0 at X and phase k at X + u_k(X), sampled trilinearly here; and phase
// k against phase 0's cubic B-spline at the truth's inverse, the spline solved
// here directly (the phantom forms every phase through the source's spline,
// after a Gaussian point-spread function of kPointSpread_voxels).
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <Eigen/Dense>

#include "io/ct/ct_reader.h"
#include "io/ct/displacement_field.h"
#include "sim/error.h"
#include "tests/support/temporary_folder.h"
#include "tests/support/text_file.h"
#include "tools/phantom/real_ct_motion.h"
#include "tests/support/real_data.h"

namespace dg::tools::phantom {
namespace {

using Catch::Matchers::Contains;

std::string Abdomen(const std::string& file) { return testing::RealData("03_ct_abdomen_totalseg/" + file); }

struct Finished {
  int exit_code = -1;
  std::string out, err;
};

// The built binary with `args`, its stdout and stderr kept in files of `folder`.
Finished RunDynaguide(const std::vector<std::string>& args, const dg::testing::TemporaryFolder& folder) {
  std::vector<std::string> argv_text = {DG_DYNAGUIDE_PATH};
  argv_text.insert(argv_text.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& arg : argv_text) argv.push_back(arg.data());
  argv.push_back(nullptr);
  const std::string out_path = folder.File("stdout.txt"), err_path = folder.File("stderr.txt");
  const int out = ::open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const int err = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  REQUIRE(out >= 0);
  REQUIRE(err >= 0);
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {  // only async-signal-safe calls until exec: the test process may have threads
    ::dup2(out, STDOUT_FILENO);
    ::dup2(err, STDERR_FILENO);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  ::close(out);
  ::close(err);
  int status = 0;
  REQUIRE(::waitpid(pid, &status, 0) == pid);
  REQUIRE(WIFEXITED(status));
  return {WEXITSTATUS(status), testing::ReadText(out_path), testing::ReadText(err_path)};
}

// The image's value at X (S, metres) by trilinear interpolation; false when X
// is not at least `margin` voxels inside the grid.
bool SampleTrilinear(const io::CtImage& image, const Eigen::Vector3d& X_S_m, double margin, double* value) {
  const Eigen::Vector3d c = (image.direction * image.spacing_m.asDiagonal()).inverse() * (X_S_m - image.origin_m);
  for (int a = 0; a < 3; ++a) {
    if (c[a] < margin || c[a] > image.size[a] - 1 - margin) return false;
  }
  const Eigen::Vector3i lo = c.array().floor().cast<int>().cwiseMin(image.size.array() - 2).matrix();
  const Eigen::Vector3d t = c - lo.cast<double>();
  *value = 0;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3i offset(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
    double weight = 1;
    for (int a = 0; a < 3; ++a) weight *= offset[a] ? t[a] : 1 - t[a];
    *value += weight * image.at(lo.x() + offset.x(), lo.y() + offset.y(), lo.z() + offset.z());
  }
  return true;
}

// The phantom's point-spread function: a Gaussian of this standard deviation
// along each axis (tools/phantom/real_ct_phantom.cc; phantom.json states it).
constexpr double kPointSpread_voxels = 0.5;

// The image through a Gaussian of sigma voxels along each axis (kernel to 3
// sigma, normalised; edge voxels repeated), in double.
std::vector<double> GaussianBlurred(const io::CtImage& image, double sigma) {
  std::vector<double> values(image.values.begin(), image.values.end());
  const int radius = static_cast<int>(std::ceil(3 * sigma));
  std::vector<double> kernel;
  for (int i = -radius; i <= radius; ++i) kernel.push_back(std::exp(-0.5 * i * i / (sigma * sigma)));
  double total = 0;
  for (double w : kernel) total += w;
  const Eigen::Vector3i n = image.size;
  for (int axis = 0; axis < 3; ++axis) {
    const std::vector<double> in = values;
    for (int k = 0; k < n.z(); ++k) {
      for (int j = 0; j < n.y(); ++j) {
        for (int i = 0; i < n.x(); ++i) {
          double sum = 0;
          for (int r = -radius; r <= radius; ++r) {
            Eigen::Vector3i at(i, j, k);
            at[axis] = std::clamp(at[axis] + r, 0, n[axis] - 1);
            sum += kernel[r + radius] * in[image.Index(at.x(), at.y(), at.z())];
          }
          values[image.Index(i, j, k)] = sum / total;
        }
      }
    }
  }
  return values;
}

// The interpolating cubic B-spline's coefficients of the image, mirror
// boundaries: along each axis the tridiagonal system (c[i-1] + 4 c[i] +
// c[i+1]) / 6 = f[i], c[-1] = c[1] and c[n] = c[n-2], solved by elimination.
std::vector<double> CubicCoefficients(const io::CtImage& image) {
  std::vector<double> c(image.values.begin(), image.values.end());
  const Eigen::Vector3i n = image.size;
  for (int axis = 0; axis < 3; ++axis) {
    const int m = n[axis];
    std::vector<double> f(m), upper(m), rhs(m);
    Eigen::Vector3i at;
    for (at.z() = 0; at.z() < (axis == 2 ? 1 : n.z()); ++at.z()) {
      for (at.y() = 0; at.y() < (axis == 1 ? 1 : n.y()); ++at.y()) {
        for (at.x() = 0; at.x() < (axis == 0 ? 1 : n.x()); ++at.x()) {
          const auto index = [&](int i) {
            Eigen::Vector3i p = at;
            p[axis] = i;
            return image.Index(p.x(), p.y(), p.z());
          };
          for (int i = 0; i < m; ++i) f[i] = 6 * c[index(i)];
          // Row i: lower[i] c[i-1] + 4 c[i] + upper[i] c[i+1] = f[i].
          const auto lower = [&](int i) { return i == m - 1 ? 2.0 : 1.0; };
          const auto upper_of = [&](int i) { return i == 0 ? 2.0 : 1.0; };
          double diagonal = 4;
          upper[0] = upper_of(0) / diagonal;
          rhs[0] = f[0] / diagonal;
          for (int i = 1; i < m; ++i) {
            diagonal = 4 - lower(i) * upper[i - 1];
            upper[i] = upper_of(i) / diagonal;
            rhs[i] = (f[i] - lower(i) * rhs[i - 1]) / diagonal;
          }
          for (int i = m - 2; i >= 0; --i) rhs[i] -= upper[i] * rhs[i + 1];
          for (int i = 0; i < m; ++i) c[index(i)] = rhs[i];
        }
      }
    }
  }
  return c;
}

// The cubic B-spline of `coefficients` (on image's grid) at X; false when X is
// not at least `margin` voxels inside the grid.
bool SampleCubic(const io::CtImage& image, const std::vector<double>& coefficients, const Eigen::Vector3d& X_S_m,
                 double margin, double* value) {
  const Eigen::Vector3d c = (image.direction * image.spacing_m.asDiagonal()).inverse() * (X_S_m - image.origin_m);
  for (int a = 0; a < 3; ++a) {
    if (c[a] < margin || c[a] > image.size[a] - 1 - margin) return false;
  }
  const auto weight = [](double d) {  // the cubic B-spline at distance d from its knot
    d = std::abs(d);
    return d < 1 ? (4 - 6 * d * d + 3 * d * d * d) / 6 : d < 2 ? (2 - d) * (2 - d) * (2 - d) / 6 : 0.0;
  };
  const auto mirrored = [](int i, int n) { return i < 0 ? -i : i > n - 1 ? 2 * (n - 1) - i : i; };
  const Eigen::Vector3i base = c.array().floor().cast<int>();
  *value = 0;
  for (int dk = -1; dk <= 2; ++dk) {
    for (int dj = -1; dj <= 2; ++dj) {
      for (int di = -1; di <= 2; ++di) {
        const Eigen::Vector3i p = base + Eigen::Vector3i(di, dj, dk);
        const double w = weight(c.x() - p.x()) * weight(c.y() - p.y()) * weight(c.z() - p.z());
        *value += w * coefficients[image.Index(mirrored(p.x(), image.size.x()), mirrored(p.y(), image.size.y()),
                                               mirrored(p.z(), image.size.z()))];
      }
    }
  }
  return true;
}

struct Consistency {
  double warped_mean_hu = 0;    // mean |I_k(X + u_k(X)) - I_0(X)|
  double unwarped_mean_hu = 0;  // mean |I_k(X) - I_0(X)|: the motion's own effect, for scale
  double reversed_mean_hu = 0;  // mean |I_k(X - u_k(X)) - I_0(X)|: the motion the wrong way
  int points = 0;
};

// Over the grid points X inside the body (phase 0 at least -300 HU) where
// the motion moves at least `min_motion_mm` and X + u(X) lies a voxel inside the grid.
Consistency Compare(const io::CtImage& first, const io::CtImage& phase, const io::DisplacementField& truth,
                    double min_motion_mm) {
  Consistency result;
  for (int k = 0; k < first.size.z(); ++k) {
    for (int j = 0; j < first.size.y(); ++j) {
      for (int i = 0; i < first.size.x(); ++i) {
        if (first.at(i, j, k) < -300) continue;
        const Eigen::Vector3d u_mm = truth.u_mm.col(truth.Index(i, j, k)).cast<double>();
        if (u_mm.norm() < min_motion_mm) continue;
        const Eigen::Vector3d X = first.PointOf(i, j, k);
        double moved = 0, unmoved = 0, reversed = 0;
        if (!SampleTrilinear(phase, X + 1e-3 * u_mm, 1, &moved) || !SampleTrilinear(phase, X, 1, &unmoved) ||
            !SampleTrilinear(phase, X - 1e-3 * u_mm, 1, &reversed)) {
          continue;
        }
        result.reversed_mean_hu += std::abs(reversed - first.at(i, j, k));
        result.warped_mean_hu += std::abs(moved - first.at(i, j, k));
        result.unwarped_mean_hu += std::abs(unmoved - first.at(i, j, k));
        ++result.points;
      }
    }
  }
  result.warped_mean_hu /= std::max(result.points, 1);
  result.unwarped_mean_hu /= std::max(result.points, 1);
  result.reversed_mean_hu /= std::max(result.points, 1);
  return result;
}

// The largest |I_k(x) - I_0(X)| over phase k's grid points x inside the body
// (at least -300 HU) and two voxels inside the grid, X the truth's inverse at x
// (X = x - u_k(X) by fixed-point iteration on the written field, trilinear),
// I_0 phase 0's cubic B-spline: the phase is the warp its truth says, up to
// the integer HU both phases are stored in and the field's interpolation.
double WorstInverseMismatchHu(const io::CtImage& first, const io::CtImage& phase, const io::DisplacementField& truth,
                              int* points) {
  const std::vector<double> coefficients = CubicCoefficients(first);
  double worst = 0;
  *points = 0;
  for (int k = 2; k < phase.size.z() - 2; ++k) {
    for (int j = 2; j < phase.size.y() - 2; ++j) {
      for (int i = 2; i < phase.size.x() - 2; ++i) {
        if (phase.at(i, j, k) < -300) continue;
        const Eigen::Vector3d x = phase.PointOf(i, j, k);
        Eigen::Vector3d X = x;
        for (int iteration = 0; iteration < 50; ++iteration) X = x - 1e-3 * truth.SampleMm(X);
        double value = 0;
        if (!SampleCubic(first, coefficients, X, 0, &value)) continue;
        worst = std::max(worst, std::abs(value - phase.at(i, j, k)));
        ++*points;
      }
    }
  }
  return worst;
}

double MaxNormMm(const io::DisplacementField& field) { return field.u_mm.colwise().norm().maxCoeff(); }

TEST_CASE("phantom --ct: a real abdominal CT and its labels into a 4D CT consistent with its truth", "[integration]") {
  const dg::testing::TemporaryFolder folder("dg_real_ct_phantom");
  const std::string out = folder.File("phantom");
  const Finished run = RunDynaguide({"phantom", "--ct", Abdomen("ct_abdomen_3mm_30slices.nii.gz"), "--labels",
                                     Abdomen("labels_totalseg_for_30slices.nii.gz"), "--out", out, "--phases", "4",
                                     "--amplitude-mm", "4", "--quiet"},
                                    folder);
  INFO(run.err);
  REQUIRE(run.exit_code == 0);
  CHECK_THAT(run.out, Contains("warped from a real CT"));
  const std::string report = testing::ReadText(out + "/phantom.json");
  CHECK_THAT(report, Contains("\"motion\": \"cardiac\""));
  CHECK_THAT(report, Contains("a real CT warped"));

  const std::vector<io::CtImage> phases = io::ReadCtPhases({out + "/ct/dicom"}, {});
  REQUIRE(phases.size() == 4);
  for (int k = 0; k < 4; ++k) CHECK(phases[k].cycle_fraction == Approx(k / 4.0).margin(1e-9));
  const io::CtImage source = io::ReadCtImage(Abdomen("ct_abdomen_3mm_30slices.nii.gz"));
  REQUIRE(phases[0].size == source.size);
  // Phase 0 is the source through the point-spread function, to DICOM's integer HU.
  const std::vector<double> blurred = GaussianBlurred(source, kPointSpread_voxels);
  double worst_hu = 0;
  for (std::size_t v = 0; v < source.num_voxels(); ++v) {
    worst_hu = std::max(worst_hu, std::abs(phases[0].values[v] - blurred[v]));
  }
  CHECK(worst_hu <= 0.5 + 1e-3);

  std::vector<io::DisplacementField> truth;
  for (int k = 0; k < 4; ++k) {
    char name[64];
    std::snprintf(name, sizeof name, "/truth/dvf_phase_%02d.mha", k);
    truth.push_back(io::ReadDisplacementField(out + name));
    REQUIRE(truth[k].size == phases[0].size);
  }
  CHECK(MaxNormMm(truth[0]) == 0);
  // The largest displacement is the amplitude, at mid-cycle (phase 2), on the grid.
  const double largest = std::max({MaxNormMm(truth[1]), MaxNormMm(truth[2]), MaxNormMm(truth[3])});
  INFO("max |u| " << largest << " mm");
  CHECK(largest >= 0.5 * 4);
  CHECK(largest <= 4 * (1 + 1e-5));

  for (int k = 1; k < 4; ++k) {
    // The brief's check: phase 0 at X against phase k at X + u_k(X), both
    // trilinear, at points that move at least a millimetre (two at mid-cycle).
    const Consistency c = Compare(phases[0], phases[k], truth[k], k == 2 ? 2.0 : 1.0);
    INFO("phase " << k << ": " << c.points << " points, |I_k(X + u) - I_0(X)| " << c.warped_mean_hu
                  << " HU, |I_k(X) - I_0(X)| " << c.unwarped_mean_hu << " HU, |I_k(X - u) - I_0(X)| "
                  << c.reversed_mean_hu << " HU");
    CHECK(c.points > 10000);
    // Measured 9.34, 8.05, 9.34 HU (phases 1-3), against 20.0, 39.8, 20.0 HU
    // unwarped and 38.3, 76.1, 38.3 HU with the motion reversed: what is left
    // is the trilinear sampling here (the phases are a cubic spline's) at the
    // 3 mm voxels of bone and skin.
    CHECK(c.warped_mean_hu < 2 * 9.4);
    CHECK(c.warped_mean_hu < 0.9 * c.unwarped_mean_hu);
    CHECK(c.warped_mean_hu < 0.6 * c.reversed_mean_hu);
    // The sharp check: each voxel of phase k is phase 0 at the truth's inverse.
    int points = 0;
    const double worst_inverse_hu = WorstInverseMismatchHu(phases[0], phases[k], truth[k], &points);
    INFO(points << " points: worst |I_k(x) - I_0(phi^-1(x))| " << worst_inverse_hu << " HU");
    CHECK(points > 100000);
    // Measured 1.19, 1.20, 1.19 HU: both phases rounded to DICOM's integer HU.
    CHECK(worst_inverse_hu < 2 * 1.2);
  }

  // The labels on the CT's grid, as given.
  const io::CtImage labels = io::ReadLabelMap(out + "/labels.nii.gz");
  const io::CtImage given = io::ReadLabelMap(Abdomen("labels_totalseg_for_30slices.nii.gz"));
  REQUIRE(labels.size == phases[0].size);
  CHECK((labels.spacing_m - phases[0].spacing_m).norm() < 1e-9);
  CHECK((labels.origin_m - phases[0].origin_m).norm() < 1e-6);
  CHECK((labels.direction - phases[0].direction).norm() < 1e-9);
  CHECK(labels.values == given.values);
}

TEST_CASE("phantom --ct: respiratory motion without labels, and a motion too strong refused", "[integration]") {
  const dg::testing::TemporaryFolder folder("dg_real_ct_phantom_breath");
  const std::string out = folder.File("phantom");
  const std::string ct = Abdomen("ct_abdomen_3mm_30slices.nii.gz");
  const Finished run = RunDynaguide(
      {"phantom", "--ct", ct, "--out", out, "--phases", "4", "--motion", "respiratory", "--ct-format", "mhd", "--quiet"},
      folder);
  INFO(run.err);
  REQUIRE(run.exit_code == 0);
  const io::CtImage first = io::ReadCtImage(out + "/ct/phase_00.mhd");
  const io::CtImage middle = io::ReadCtImage(out + "/ct/phase_02.mhd");
  const io::DisplacementField truth = io::ReadDisplacementField(out + "/truth/dvf_phase_02.mha");
  // Mostly towards the feet (-z in LPS): the mean displacement points down.
  const Eigen::Vector3d mean_mm = truth.u_mm.rowwise().mean().cast<double>();
  CHECK(mean_mm.z() < -3 * std::abs(mean_mm.x()));
  CHECK(MaxNormMm(truth) == Approx(4).epsilon(0.05));
  const Consistency c = Compare(first, middle, truth, 2);
  INFO(c.points << " points: " << c.warped_mean_hu << " HU warped, " << c.unwarped_mean_hu << " HU unwarped, "
                << c.reversed_mean_hu << " HU reversed");
  CHECK(c.points > 10000);
  // Measured 3.77 HU warped, 20.9 unwarped, 33.7 reversed.
  CHECK(c.warped_mean_hu < 0.9 * c.unwarped_mean_hu);
  CHECK(c.warped_mean_hu < 0.6 * c.reversed_mean_hu);
  int points = 0;
  const double worst_hu = WorstInverseMismatchHu(first, middle, truth, &points);
  INFO(points << " points: worst |I_k(x) - I_0(phi^-1(x))| " << worst_hu << " HU");
  CHECK(points > 100000);
  CHECK(worst_hu < 2 * 1.16);  // measured 1.16 HU (both phases MetaImage int16, rounded)

  const std::string refused = folder.File("refused");
  const Finished strong = RunDynaguide({"phantom", "--ct", ct, "--out", refused, "--amplitude-mm", "30"}, folder);
  CHECK(strong.exit_code != 0);
  CHECK_THAT(strong.err, Contains("Jacobian determinant"));
  CHECK_THAT(strong.err, Contains("--amplitude-mm"));
  CHECK(!std::filesystem::exists(refused + "/ct"));  // refused before writing
}

// The motion model itself, against its definition.
RealCtMotion::Parameters CardiacParameters() {
  RealCtMotion::Parameters p;
  p.kind = RealCtMotion::Kind::kCardiac;
  p.centre_S_m = Eigen::Vector3d(0.01, -0.02, 0.15);
  p.axis_S = Eigen::Vector3d(1, 2, 3);
  p.window_m = 0.05;
  p.amplitude_m = 0.004;
  p.twist = 0.6;
  p.shortening = 0.4;
  return p;
}

TEST_CASE("RealCtMotion: inverse, amplitude and Jacobian", "[unit]") {
  for (const RealCtMotion::Kind kind : {RealCtMotion::Kind::kCardiac, RealCtMotion::Kind::kRespiratory}) {
    RealCtMotion::Parameters p = CardiacParameters();
    p.kind = kind;
    const RealCtMotion motion(p);
    CHECK(motion.Displacement(p.centre_S_m + Eigen::Vector3d(0.03, 0.01, 0), 0).norm() == 0);
    std::mt19937 random(7);
    std::uniform_real_distribution<double> offset(-0.12, 0.12);
    double worst_inverse_m = 0, largest_m = 0;
    for (int n = 0; n < 20000; ++n) {
      const Eigen::Vector3d X = p.centre_S_m + Eigen::Vector3d(offset(random), offset(random), offset(random)) / 2;
      const Eigen::Vector3d x = X + motion.Displacement(X, 0.5);
      worst_inverse_m = std::max(worst_inverse_m, (motion.Undeform(x, 0.5) - X).norm());
      largest_m = std::max(largest_m, motion.Displacement(X, 0.5).norm());
    }
    INFO(RealCtMotion::KindName(kind) << ": inverse " << 1e3 * worst_inverse_m << " mm, largest " << 1e3 * largest_m);
    CHECK(worst_inverse_m < 1e-7);  // 1e-4 mm
    CHECK(largest_m <= p.amplitude_m * (1 + 1e-6));
    CHECK(largest_m > 0.95 * p.amplitude_m);  // random points come near the maximum
  }
  // At the centre the cardiac gradient is -(s (I - n n^T) + s shortening n n^T),
  // s = amplitude / (window max|g|): det (1 - s)^2 (1 - s shortening), the smallest.
  const RealCtMotion cardiac(CardiacParameters());
  const Eigen::Vector3d X = CardiacParameters().centre_S_m;
  const double h = 1e-6;
  Eigen::Matrix3d jacobian = Eigen::Matrix3d::Identity();
  for (int a = 0; a < 3; ++a) {
    const Eigen::Vector3d step = h * Eigen::Vector3d::Unit(a);
    jacobian.col(a) += (cardiac.Displacement(X + step, 0.5) - cardiac.Displacement(X - step, 0.5)) / (2 * h);
  }
  const RealCtMotion::JacobianBounds bounds = cardiac.Jacobian(0.5);
  INFO("det at the centre " << jacobian.determinant() << ", lattice minimum " << bounds.min_determinant);
  CHECK(bounds.min_determinant == Approx(jacobian.determinant()).epsilon(1e-3));
  CHECK(cardiac.Jacobian(0.25).min_determinant > bounds.min_determinant);  // half the activation
  CHECK(cardiac.Jacobian(0).min_determinant == 1);

  RealCtMotion::Parameters wrong = CardiacParameters();
  wrong.window_m = 0;
  CHECK_THROWS_AS(RealCtMotion(wrong), Error);
}

}  // namespace
}  // namespace dg::tools::phantom
