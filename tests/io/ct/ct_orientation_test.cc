// The readers put every image on the scan frame's axes: flips and exchanges
// of axes moved exactly (files ITK writes in several orientations, a real
// RAS NIfTI against nibabel, a real label map against its DICOM CT), oblique
// grids resampled (against a smooth function of the physical point).
#include "io/ct/axis_aligned.h"

#include <cmath>
#include <memory>

#include <Eigen/Dense>
#include <catch2/catch.hpp>
#include <spdlog/sinks/ringbuffer_sink.h>

#include "io/ct/ct_reader.h"
#include "io/ct/dicom_writer.h"
#include "io/ct/image_file_writer.h"
#include "sim/log.h"
#include "tests/io/ct/ct_fixtures.h"
#include "tests/support/real_data.h"
#include "tests/support/temporary_folder.h"

namespace dg::io {
namespace {

using Catch::Matchers::Contains;
using Catch::Matchers::WithinAbs;

std::string Abdomen(const std::string& file) { return dg::testing::RealData("03_ct_abdomen_totalseg/" + file); }

// The same voxels at the same physical points as `aligned` (direction the
// identity), on a grid whose voxel axis a is S axis `axis[a]`, along it or
// against it: what a scanner or converter writing another orientation writes.
CtImage InOrientation(const CtImage& aligned, const Eigen::Vector3i& axis, const Eigen::Vector3i& sign) {
  CtImage file;
  Eigen::Vector3d first;  // the aligned index of the file's voxel (0, 0, 0)
  file.direction.setZero();
  for (int a = 0; a < 3; ++a) {
    file.size[a] = aligned.size[axis[a]];
    file.spacing_m[a] = aligned.spacing_m[axis[a]];
    file.direction(axis[a], a) = sign[a];
    first[axis[a]] = sign[a] > 0 ? 0 : aligned.size[axis[a]] - 1;
  }
  file.origin_m = aligned.PointOf(first.x(), first.y(), first.z());
  file.values.resize(aligned.num_voxels());
  for (int k = 0; k < file.size.z(); ++k) {
    for (int j = 0; j < file.size.y(); ++j) {
      for (int i = 0; i < file.size.x(); ++i) {
        const Eigen::Vector3d g = aligned.direction.inverse() * (file.PointOf(i, j, k) - aligned.origin_m);
        const Eigen::Vector3d index = g.cwiseQuotient(aligned.spacing_m);
        file.values[file.Index(i, j, k)] =
            aligned.at(int(std::lround(index.x())), int(std::lround(index.y())), int(std::lround(index.z())));
      }
    }
  }
  return file;
}

TEST_CASE("ct orientation: axis codes and angles of direction matrices", "[unit]") {
  REQUIRE(MatchAxes(Eigen::Matrix3d::Identity()).Code() == "LPS");
  REQUIRE(MatchAxes(Eigen::Vector3d(-1, -1, 1).asDiagonal().toDenseMatrix()).Code() == "RAS");
  Eigen::Matrix3d sagittal;  // rows along -y (A), columns along -z (I), slices along +x (L)
  sagittal << 0, 0, 1,  //
      -1, 0, 0,         //
      0, -1, 0;
  const AxisMatch match = MatchAxes(sagittal);
  REQUIRE(match.Code() == "AIL");
  REQUIRE(match.is_signed_permutation);
  const AxisMatch tilted = MatchAxes(Eigen::AngleAxisd(30 * M_PI / 180, Eigen::Vector3d::UnitX()).toRotationMatrix());
  REQUIRE(!tilted.is_signed_permutation);
  REQUIRE_THAT(tilted.largest_angle_deg, WithinAbs(30, 1e-9));
}

TEST_CASE("ct orientation: a CT written in other orientations reads to the same grid and the same voxels", "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_orientations");
  // Millimetre values that float headers (NIfTI) hold exactly.
  const CtImage truth = testing::PatternCt({7, 5, 4}, {0.75e-3, 0.5e-3, 1.25e-3}, {-0.0125, 0.03025, -0.007},
                                           Eigen::Matrix3d::Identity());
  struct Orientation {
    std::string code;
    Eigen::Vector3i axis, sign;
  };
  const std::vector<Orientation> orientations = {
      {"LPS", {0, 1, 2}, {1, 1, 1}},    // identity
      {"RAS", {0, 1, 2}, {-1, -1, 1}},  // NIfTI's convention, diag(-1, -1, 1) in LPS
      {"SLP", {2, 0, 1}, {1, 1, 1}},    // the axes exchanged
      {"LPI", {0, 1, 2}, {1, 1, -1}},   // z flipped (slices stored head first)
      {"AIL", {1, 2, 0}, {-1, -1, 1}},  // a sagittal series
  };
  double worst_origin_m = 0;
  for (const Orientation& orientation : orientations) {
    const CtImage file = InOrientation(truth, orientation.axis, orientation.sign);
    REQUIRE(MatchAxes(file.direction).Code() == orientation.code);
    const std::string stem = temporary.path() + "/" + orientation.code;
    WriteDicomSeries(file, stem + "_dicom", testing::PhaseInfo(orientation.code, 1, 1));
    WriteImageFile(file, stem + ".nii.gz", StoredPixel::kInt16);
    WriteImageFile(file, stem + ".mha", StoredPixel::kInt16);
    // DICOM's slice axis is the cross product of the row and column axes: a left-handed grid reads
    // with its slices in the other order.
    Eigen::Matrix3d dicom = file.direction;
    dicom.col(2) = dicom.col(0).cross(dicom.col(1));
    for (const std::string& path : {stem + "_dicom", stem + ".nii.gz", stem + ".mha"}) {
      INFO(path);
      const CtImage ct = ReadCtImage(path);
      const std::string code = path == stem + "_dicom" ? MatchAxes(dicom).Code() : orientation.code;
      REQUIRE(ct.reoriented_from == (code == "LPS" ? "" : code));
      REQUIRE(ct.size == truth.size);
      REQUIRE(ct.direction == Eigen::Matrix3d::Identity());
      REQUIRE((ct.spacing_m - truth.spacing_m).cwiseAbs().maxCoeff() < 1e-12);
      worst_origin_m = std::max(worst_origin_m, (ct.origin_m - truth.origin_m).cwiseAbs().maxCoeff());
      REQUIRE((ct.origin_m - truth.origin_m).cwiseAbs().maxCoeff() < 1e-9);
      REQUIRE(ct.values == truth.values);
    }
  }
  WARN("largest origin difference over the orientations and formats: " << worst_origin_m << " m");
}

TEST_CASE("ct orientation: a real RAS NIfTI reads to the voxels nibabel puts at the same physical points",
          "[integration]") {
  // TotalSegmentator's example_ct_sm.nii.gz (data README.txt): 122 x 101 x 30, 3 mm, RAS, int16 HU.
  const CtImage ct = ReadCtImage(Abdomen("ct_abdomen_3mm_30slices.nii.gz"));
  REQUIRE(ct.reoriented_from == "RAS");
  REQUIRE(ct.size == Eigen::Vector3i(122, 101, 30));
  REQUIRE(ct.direction == Eigen::Matrix3d::Identity());
  REQUIRE((ct.spacing_m - Eigen::Vector3d::Constant(3e-3)).cwiseAbs().maxCoeff() < 1e-9);
  // Computed once with Debian's python3-nibabel 5.0: img.affine @ (i, j, k, 1) of the file's voxel
  // (121 - i, 100 - j, k), x and y negated (RAS to LPS), and np.asarray(img.dataobj)[121 - i, 100 - j, k].
  struct Voxel {
    Eigen::Vector3i index;
    Eigen::Vector3d lps_mm;
    float hu;
  };
  const std::vector<Voxel> voxels = {
      {{0, 0, 0}, {-185.04367065, -311.31900024, 94.30175781}, -989},
      {{10, 20, 5}, {-155.04367065, -251.31900024, 109.30175781}, -996},
      {{60, 50, 15}, {-5.04367065, -161.31900024, 139.30175781}, 0},
      {{100, 80, 29}, {114.95632935, -71.31900024, 181.30175781}, 3},
  };
  for (const Voxel& voxel : voxels) {
    INFO(voxel.index.transpose());
    const Eigen::Vector3d point = ct.PointOf(voxel.index.x(), voxel.index.y(), voxel.index.z());
    // NIfTI's header holds the affine as float: 1e-5 mm of rounding at 200 mm.
    REQUIRE((point - 1e-3 * voxel.lps_mm).cwiseAbs().maxCoeff() < 2e-8);
    REQUIRE(ct.at(voxel.index.x(), voxel.index.y(), voxel.index.z()) == voxel.hu);
  }
}

TEST_CASE("ct orientation: a real TotalSegmentator label map (LAS NIfTI) lands on its DICOM CT's grid and organs",
          "[integration]") {
  // The data README.txt: dicom_raw/ is 20 slices of a Siemens abdominal CT (LPS), and
  // labels_totalseg_for_dicom.nii.gz its TotalSegmentator label map, 512 x 512 x 20, stored LAS.
  const CtImage ct = ReadCtImage(Abdomen("dicom_raw"));
  const CtImage labels = ReadLabelMap(Abdomen("labels_totalseg_for_dicom.nii.gz"));
  REQUIRE(ct.reoriented_from.empty());
  REQUIRE(labels.reoriented_from == "LAS");
  REQUIRE(!labels.values_are_hu);
  REQUIRE(labels.size == ct.size);
  REQUIRE(labels.direction == ct.direction);
  REQUIRE((labels.spacing_m - ct.spacing_m).cwiseAbs().maxCoeff() < 1e-9);
  REQUIRE(((labels.origin_m - ct.origin_m).cwiseAbs().array() < 1e-3 * ct.spacing_m.array()).all());
  // The organs over the right voxels: the mean HU under TotalSegmentator's spleen (1) and liver (5),
  // computed once with pydicom (rescale applied) and nibabel (the label array's j reversed, LAS to
  // LPS): 79.5686 and 89.3046 HU over 130634 and 366708 voxels. Unflipped they would be -377 and -75.
  for (const auto& [label, count, mean_hu] : {std::tuple{1, 130634, 79.5686}, {5, 366708, 89.3046}}) {
    double sum = 0;
    int n = 0;
    for (size_t v = 0; v < ct.num_voxels(); ++v) {
      if (labels.values[v] == label) {
        sum += ct.values[v];
        ++n;
      }
    }
    INFO("label " << label);
    REQUIRE(n == count);
    REQUIRE_THAT(sum / n, WithinAbs(mean_hu, 1e-4));
  }
}

// A smooth field of the physical point (metres) in HU: quadratic in x and y, linear in z.
double SmoothHu(const Eigen::Vector3d& x) {
  return -650 + 2e5 * (x.x() * x.x() + x.y() * x.y()) + 5000 * x.x() - 3000 * x.y() + 1000 * x.z();
}

TEST_CASE("ct orientation: an oblique CT is resampled onto S's axes, with a warning naming the angle", "[unit]") {
  const testing::TemporaryFolder temporary("dg_ct_oblique");
  CtImage file;
  file.size = {24, 20, 6};
  file.spacing_m = {1e-3, 1.2e-3, 2e-3};
  file.origin_m = {-0.011, -0.013, -0.004};
  file.direction = Eigen::AngleAxisd(10 * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  file.values.resize(file.num_voxels());
  for (int k = 0; k < file.size.z(); ++k) {
    for (int j = 0; j < file.size.y(); ++j) {
      for (int i = 0; i < file.size.x(); ++i) file.values[file.Index(i, j, k)] = float(SmoothHu(file.PointOf(i, j, k)));
    }
  }
  WriteImageFile(file, temporary.File("oblique.mha"), StoredPixel::kFloat32);

  auto log = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(8);
  Logger("io").sinks().push_back(log);
  const CtImage ct = ReadCtImage(temporary.File("oblique.mha"));
  Logger("io").sinks().pop_back();

  REQUIRE_THAT(ct.oblique_angle_deg, WithinAbs(10, 0.01));
  REQUIRE(ct.reoriented_from == "oblique 10.0 deg");
  const std::vector<std::string> lines = log->last_formatted(8);
  REQUIRE(!lines.empty());
  REQUIRE_THAT(lines.back(), Contains("10.00 degrees") && Contains("oblique.mha") && Contains("resampled"));

  REQUIRE(ct.direction == Eigen::Matrix3d::Identity());
  REQUIRE((ct.spacing_m - file.spacing_m).cwiseAbs().maxCoeff() < 1e-15);
  // The grid covers the voxel centres' bounding box: rotated by 10 degrees about z, x spans
  // 23 cos10 + 19 (1.2) sin10 mm and y 23 sin10 + 19 (1.2) cos10 mm.
  const double c = std::cos(10 * M_PI / 180), s = std::sin(10 * M_PI / 180);
  REQUIRE(ct.size == Eigen::Vector3i(int(std::ceil(23 * c + 22.8 * s)) + 1, int(std::ceil((23 * s + 22.8 * c) / 1.2)) + 1, 6));
  REQUIRE_THAT(ct.origin_m.x(), WithinAbs(file.origin_m.x() - 1e-3 * 22.8 * s, 1e-12));
  REQUIRE_THAT(ct.origin_m.y(), WithinAbs(file.origin_m.y(), 1e-12));

  // Inside the file's voxels the value is the field's at the point, within linear interpolation's
  // error on a quadratic: (|f_uu| + |f_vv|) h^2 / 8 = 8e5 * (1.2e-3)^2 / 8 = 0.144 HU at most.
  double worst = 0;
  int inside = 0, outside = 0;
  const Eigen::Matrix3d to_file = file.direction.transpose();
  for (int k = 0; k < ct.size.z(); ++k) {
    for (int j = 0; j < ct.size.y(); ++j) {
      for (int i = 0; i < ct.size.x(); ++i) {
        const Eigen::Vector3d x = ct.PointOf(i, j, k);
        const Eigen::Vector3d u = (to_file * (x - file.origin_m)).cwiseQuotient(file.spacing_m);
        const bool within = (u.array() >= -1e-9).all() && (u.array() <= file.size.cast<double>().array() - 1 + 1e-9).all();
        const bool beyond = (u.array() < -0.5 - 1e-9).any() || (u.array() > file.size.cast<double>().array() - 0.5 + 1e-9).any();
        if (within) {
          ++inside;
          worst = std::max(worst, std::abs(ct.at(i, j, k) - SmoothHu(x)));
        } else if (beyond) {
          ++outside;
          REQUIRE(ct.at(i, j, k) == -1024);
        }
      }
    }
  }
  REQUIRE(inside > 1500);
  REQUIRE(outside > 100);
  WARN("oblique resampling: worst error " << worst << " HU over " << inside << " voxels");
  REQUIRE(worst < 0.144);
}

TEST_CASE("ct orientation: an oblique label map is resampled by nearest voxel, labels kept", "[unit]") {
  CtImage labels;
  labels.size = {9, 8, 3};
  labels.spacing_m = {1e-3, 1e-3, 1e-3};
  labels.direction = Eigen::AngleAxisd(0.2, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  for (int v = 0; v < 9 * 8 * 3; ++v) labels.values.push_back(float(v % 5));
  const CtImage aligned = OnAxisAlignedGrid(labels, Interpolation::kNearest, 0);
  for (int k = 0; k < aligned.size.z(); ++k) {
    for (int j = 0; j < aligned.size.y(); ++j) {
      for (int i = 0; i < aligned.size.x(); ++i) {
        // Every value is a label of the file, or 0 outside: nothing between labels.
        const float value = aligned.at(i, j, k);
        REQUIRE(value == std::round(value));
        REQUIRE(value >= 0);
        REQUIRE(value <= 4);
        // At a point inside the file's voxels, the label of the file's nearest voxel.
        const Eigen::Vector3d u = labels.direction.transpose() * (aligned.PointOf(i, j, k) - labels.origin_m) / 1e-3;
        const Eigen::Vector3d r = u.array().round();
        if ((u - r).cwiseAbs().maxCoeff() < 0.49 && (r.array() >= 0).all() &&
            (r.array() <= labels.size.cast<double>().array() - 1).all()) {
          REQUIRE(value == labels.at(int(r.x()), int(r.y()), int(r.z())));
        }
      }
    }
  }
}

}  // namespace
}  // namespace dg::io
