#pragma once

// Small CTs for the CT reading and writing tests. Header-only.
#include <string>

#include <Eigen/Geometry>

#include "io/ct/ct_image.h"
#include "io/ct/dicom_writer.h"

namespace dg::testing {

// A rotation about a tilted axis: an oblique scan.
inline Eigen::Matrix3d ObliqueDirection() {
  return Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
}

// A CT whose voxel (i, j, k) holds -1000 + i + 10 j + 100 k + offset HU.
inline io::CtImage PatternCt(const Eigen::Vector3i& size, const Eigen::Vector3d& spacing_m,
                             const Eigen::Vector3d& origin_m, const Eigen::Matrix3d& direction, int offset = 0) {
  io::CtImage ct;
  ct.size = size;
  ct.spacing_m = spacing_m;
  ct.origin_m = origin_m;
  ct.direction = direction;
  for (int k = 0; k < size.z(); ++k) {
    for (int j = 0; j < size.y(); ++j) {
      for (int i = 0; i < size.x(); ++i) ct.values.push_back(static_cast<float>(-1000 + i + 10 * j + 100 * k + offset));
    }
  }
  return ct;
}

inline io::CtImage SmallCt(int offset = 0) {
  return PatternCt({5, 4, 3}, {0.8e-3, 0.8e-3, 1.5e-3}, {-0.01, 0.02, -0.03}, Eigen::Matrix3d::Identity(), offset);
}

// The series information of phase `position` (from 1) of `positions`, in the study named `study`.
inline io::DicomSeriesInfo PhaseInfo(const std::string& study, int position, int positions) {
  io::DicomSeriesInfo info;
  info.patient_id = "TEST";
  info.patient_name = "Test^Phantom";
  info.study_uid = io::DeterministicUid(study);
  info.series_uid = io::DeterministicUid(study + " phase " + std::to_string(position));
  info.series_description = "phase " + std::to_string(position);
  info.series_number = position;
  info.date = "20200229";
  info.temporal_position = position;
  info.temporal_positions = positions;
  return info;
}

}  // namespace dg::testing
