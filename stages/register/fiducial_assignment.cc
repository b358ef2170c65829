#include "stages/register/fiducial_assignment.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <utility>

// GCC 12 sees, falsely, an 8-double AVX-512 load of a 3-vector in
// Eigen::umeyama's dynamic-size block copy (a path taken only for 8 rows or
// more). Geometry, umeyama's header, is first included here.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Warray-bounds"
#include <Eigen/Geometry>
#pragma GCC diagnostic pop
#include <ceres/ceres.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "sim/error.h"
#include "stages/register/reprojection_residual.h"

namespace dg::stages {
namespace {

// Original (distorted) pixels to the normalised image plane of one eye.
Eigen::Vector2d Normalised(const io::CameraCalibration& eye, const Eigen::Vector2d& uv_px) {
  cv::Mat K, D(1, 8, CV_64F, const_cast<double*>(eye.distortion.data()));
  cv::eigen2cv(eye.K, K);
  std::vector<cv::Point2d> in{{uv_px.x(), uv_px.y()}}, out;
  cv::undistortPoints(in, out, K, D);
  return {out[0].x, out[0].y};
}

// The point nearest both viewing rays (the midpoint of their common
// perpendicular), in the left camera's frame C; the right eye sees R x + T.
Eigen::Vector3d Triangulated(const io::StereoCalibration& calibration, const FiducialSighting& s) {
  const Eigen::Vector3d ray_left = Normalised(calibration.left, s.uv_left_px).homogeneous().normalized();
  const Eigen::Vector3d ray_right =
      calibration.R.transpose() * Normalised(calibration.right, s.uv_right_px).homogeneous().normalized();
  const Eigen::Vector3d origin_right = -calibration.R.transpose() * calibration.T_m;
  // Minimise |s ray_left - (origin_right + t ray_right)| over s and t.
  const Eigen::Vector3d w = -origin_right;
  const double d = ray_left.dot(ray_right), along_left = ray_left.dot(w), along_right = ray_right.dot(w);
  const double denominator = 1 - d * d;  // the rays are never parallel for a point in front of both eyes
  const double s_left = (d * along_right - along_left) / denominator;
  const double t_right = (along_right - d * along_left) / denominator;
  return 0.5 * (s_left * ray_left + origin_right + t_right * ray_right);
}

// A triangulated sighting farther than this from its track's median position
// is a gross tracking error (a wrong match in one eye puts it centimetres off
// in depth), not the marker's beat of a few millimetres: left out of the means.
constexpr double kGrossErrorM = 10e-3;

// Orders ranked by the 3-D fit whose image fit is then measured: the right one
// is among the first few (a wrong order is centimetres off in 3-D, depth noise
// millimetres), and an image fit costs a pose solve.
constexpr int kImageFitted = 24;

// Each track's mean position over the frames both eyes saw it, gross errors
// left out: triangulated in the left camera's frame C, and in the left image.
struct TrackMeans {
  Eigen::Matrix3Xd xyz_C_m;
  std::vector<cv::Point2d> uv_left_px;
  std::vector<Eigen::Vector2d> uv_right_px;
};

TrackMeans MeansOf(const io::StereoCalibration& calibration, const FiducialTracks& tracks, int F) {
  TrackMeans means{Eigen::Matrix3Xd(3, F), std::vector<cv::Point2d>(F), std::vector<Eigen::Vector2d>(F)};
  for (int i = 0; i < F; ++i) {
    std::vector<Eigen::Vector3d> points;
    std::vector<Eigen::Vector2d> pixels, right_pixels;
    for (const std::vector<FiducialSighting>& frame : tracks.frames) {
      if (!frame[i].in_left || !frame[i].in_right) continue;
      points.push_back(Triangulated(calibration, frame[i]));
      pixels.push_back(frame[i].uv_left_px);
      right_pixels.push_back(frame[i].uv_right_px);
    }
    if (points.empty()) {
      throw Error("fiducial " + std::to_string(i) + " is never seen by both eyes in the same frame", "registration",
                  "check its tracking in the right video (its stereo match), or leave it out of the scan's fiducials");
    }
    Eigen::Vector3d median;
    for (int c = 0; c < 3; ++c) {
      std::vector<double> values;
      for (const Eigen::Vector3d& p : points) values.push_back(p[c]);
      std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
      median[c] = values[values.size() / 2];
    }
    Eigen::Vector3d xyz_sum = Eigen::Vector3d::Zero();
    Eigen::Vector2d uv_sum = Eigen::Vector2d::Zero(), right_sum = Eigen::Vector2d::Zero();
    int kept = 0;
    for (size_t k = 0; k < points.size(); ++k) {
      if ((points[k] - median).norm() > kGrossErrorM) continue;
      xyz_sum += points[k];
      uv_sum += pixels[k];
      right_sum += right_pixels[k];
      ++kept;
    }
    means.xyz_C_m.col(i) = xyz_sum / std::max(1, kept);
    means.uv_left_px[i] = {uv_sum.x() / std::max(1, kept), uv_sum.y() / std::max(1, kept)};
    means.uv_right_px[i] = right_sum / std::max(1, kept);
  }
  return means;
}

// Each fiducial's mean over the cycle of its piecewise-linear cyclic motion:
// every segment contributes its midpoint times its length.
Eigen::Matrix3Xd CycleMeans_S(const FiducialMotion& motion) {
  const int P = motion.num_phases();
  Eigen::Matrix3Xd mean = Eigen::Matrix3Xd::Zero(3, motion.num_fiducials());
  for (int k = 0; k < P; ++k) {
    const int next = (k + 1) % P;
    const double length = (next == 0 ? motion.phases[0] + 1.0 : motion.phases[next]) - motion.phases[k];
    mean += 0.5 * length * (motion.positions_S_m[k] + motion.positions_S_m[next]);
  }
  return mean;
}

// The rms distance of the best rigid motion of the scan means onto the
// triangulated means, scan point scan_of_track[i] to track i.
double RigidFitRms_m(const Eigen::Matrix3Xd& scan_S, const Eigen::Matrix3Xd& tracks_C, const std::vector<int>& scan_of_track) {
  Eigen::Matrix3Xd matched(3, tracks_C.cols());
  for (int i = 0; i < tracks_C.cols(); ++i) matched.col(i) = scan_S.col(scan_of_track[i]);
  const Eigen::Matrix4d T = Eigen::umeyama(matched, tracks_C, false);
  const Eigen::Matrix3Xd fitted = (T.topLeftCorner<3, 3>() * matched).colwise() + T.topRightCorner<3, 1>();
  return std::sqrt((fitted - tracks_C).squaredNorm() / static_cast<double>(tracks_C.cols()));
}

// A camera pose T_C_S: angle-axis rotation and translation (metres).
struct CameraPose {
  double rotation[3] = {0, 0, 0};
  double translation_m[3] = {0, 0, 0};
};

struct ImageFit {
  CameraPose pose;
  std::vector<double> residuals_px;  // per track; infinite when no pose was found
};

// Each track's distance, in pixels (rms of the two eyes), from the scan mean
// assigned to it under the camera pose that fits the tracks best in both
// images, refined over both eyes from the left image's PnP (or from `start`).
// Both eyes make depth count as the cameras measure it (a marker's
// disparity), so a track beside its marker at another depth shows, and a
// depth poorly measured counts only as much as its pixels say. A track
// `left_out` is not fitted, only measured.
ImageFit FitInImages(const Eigen::Matrix3Xd& scan_S, const TrackMeans& means, const io::StereoCalibration& calibration,
                     const std::array<EyeModel, 2>& eyes, const std::vector<int>& scan_of_track,
                     const CameraPose* start = nullptr, int left_out = -1) {
  ImageFit fit;
  fit.residuals_px.assign(scan_of_track.size(), std::numeric_limits<double>::infinity());
  std::vector<cv::Point3d> object;
  for (int scan : scan_of_track) object.emplace_back(scan_S(0, scan), scan_S(1, scan), scan_S(2, scan));
  if (start) {
    fit.pose = *start;
  } else {
    cv::Mat K, D(1, 8, CV_64F, const_cast<double*>(calibration.left.distortion.data())), rvec, tvec;
    cv::eigen2cv(calibration.left.K, K);
    if (!cv::solvePnP(object, means.uv_left_px, K, D, rvec, tvec, false, cv::SOLVEPNP_EPNP)) return fit;
    cv::solvePnPRefineLM(object, means.uv_left_px, K, D, rvec, tvec);
    for (int k = 0; k < 3; ++k) {
      fit.pose.rotation[k] = rvec.at<double>(k);
      fit.pose.translation_m[k] = tvec.at<double>(k);
    }
  }

  std::vector<std::array<StaticPointResidual, 2>> terms;
  ceres::Problem problem;
  for (size_t i = 0; i < object.size(); ++i) {
    const Eigen::Vector3d x_S(object[i].x, object[i].y, object[i].z);
    const std::array<Eigen::Vector2d, 2> observed = {Eigen::Vector2d(means.uv_left_px[i].x, means.uv_left_px[i].y),
                                                     means.uv_right_px[i]};
    terms.push_back({StaticPointResidual{&eyes[0], x_S, observed[0]}, StaticPointResidual{&eyes[1], x_S, observed[1]}});
    if (static_cast<int>(i) == left_out) continue;
    for (const StaticPointResidual& term : terms.back()) {
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<StaticPointResidual, 2, 3, 3>(new StaticPointResidual(term)),
                               nullptr, fit.pose.rotation, fit.pose.translation_m);
    }
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.logging_type = ceres::SILENT;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  if (!summary.IsSolutionUsable()) return fit;
  for (size_t i = 0; i < terms.size(); ++i) {
    double squared = 0;
    for (const StaticPointResidual& term : terms[i]) {
      double r[2];
      if (!term(fit.pose.rotation, fit.pose.translation_m, r)) {  // behind an eye: no fit
        squared = std::numeric_limits<double>::infinity();
        break;
      }
      squared += r[0] * r[0] + r[1] * r[1];
    }
    fit.residuals_px[i] = std::sqrt(squared / 2);
  }
  return fit;
}

double Rms(const std::vector<double>& values) {
  double sum = 0;
  for (double v : values) sum += v * v;
  return std::sqrt(sum / static_cast<double>(values.size()));
}

}  // namespace

FiducialAssignment AssignFiducials(const FiducialMotion& motion, const io::StereoCalibration& calibration,
                                   const FiducialTracks& tracks, double tolerance_px) {
  const int F = motion.num_fiducials();
  std::vector<int> given(F);
  std::iota(given.begin(), given.end(), 0);
  FiducialAssignment result;
  result.scan_of_track = given;
  if (F < FiducialAssignment::kMinSearchedFiducials) return result;  // unchecked: nothing to measure it by
  const Eigen::Matrix3Xd scan_S = CycleMeans_S(motion);
  const TrackMeans means = MeansOf(calibration, tracks, F);
  const std::array<EyeModel, 2> eyes = {EyeModel::Left(calibration), EyeModel::Right(calibration)};

  // Every order ranked by its 3-D fit; the order given is always measured.
  std::vector<std::pair<double, std::vector<int>>> ranked;
  const bool search = F <= FiducialAssignment::kMaxSearchedFiducials;  // else the order given alone
  std::vector<int> candidate = given;
  do {
    ranked.emplace_back(RigidFitRms_m(scan_S, means.xyz_C_m, candidate), candidate);
  } while (search && std::next_permutation(candidate.begin(), candidate.end()));
  const size_t measured = std::min<size_t>(ranked.size(), kImageFitted);
  std::partial_sort(ranked.begin(), ranked.begin() + measured, ranked.end());
  ranked.resize(measured);
  if (std::find_if(ranked.begin(), ranked.end(), [&](const auto& r) { return r.second == given; }) == ranked.end()) {
    ranked.emplace_back(0, given);
  }

  // The best image fit and the best of any other order.
  std::vector<int> best;
  ImageFit best_fit;
  double best_rms = std::numeric_limits<double>::infinity();
  result.runner_up_rms_px = std::numeric_limits<double>::infinity();
  for (const auto& [rigid_rms, order] : ranked) {
    ImageFit fit = FitInImages(scan_S, means, calibration, eyes, order);
    const double rms = Rms(fit.residuals_px);
    if (order == given) result.given_rms_px = rms;
    if (rms < best_rms) {
      result.runner_up_rms_px = std::min(result.runner_up_rms_px, best_rms);
      best_rms = rms;
      best = order;
      best_fit = std::move(fit);
    } else {
      result.runner_up_rms_px = std::min(result.runner_up_rms_px, rms);
    }
  }

  // Each track against the pose the others fit: a single track beside its
  // marker pulls the joint fit towards itself and spreads its error over the
  // others, but stands out against theirs.
  const auto departures_under = [&](const std::vector<int>& order, const ImageFit& joint) {
    std::vector<double> departures(F, 0.0);
    if (F <= FiducialAssignment::kMinSearchedFiducials) return departures;  // four points: one pose, no check
    for (int i = 0; i < F; ++i) {
      departures[i] = FitInImages(scan_S, means, calibration, eyes, order, &joint.pose, i).residuals_px[i];
    }
    return departures;
  };
  std::vector<double> departures = departures_under(best, best_fit);
  const double worst_departure = *std::max_element(departures.begin(), departures.end());

  using Verdict = FiducialAssignment::Verdict;
  if (best_rms > tolerance_px || worst_departure > FiducialAssignment::kDepartureFactor * tolerance_px) {
    result.verdict = Verdict::kNoneFits;
  } else if (result.given_rms_px <= tolerance_px) {
    result.verdict = Verdict::kGiven;
  } else if (result.runner_up_rms_px <= tolerance_px) {
    result.verdict = Verdict::kAmbiguous;
  } else {
    result.verdict = Verdict::kReassigned;
  }
  if (result.verdict == Verdict::kGiven && best != given) {
    best = given;
    best_fit = FitInImages(scan_S, means, calibration, eyes, given);
    departures = departures_under(given, best_fit);
  }
  result.scan_of_track = result.verdict == Verdict::kReassigned ? best : given;
  result.track_residual_px = best_fit.residuals_px;
  result.track_departure_px = departures;
  result.rms_px = Rms(best_fit.residuals_px);
  return result;
}

FiducialTracks Reordered(const FiducialTracks& tracks, const std::vector<int>& scan_of_track) {
  FiducialTracks reordered = tracks;
  for (size_t j = 0; j < tracks.frames.size(); ++j) {
    for (size_t i = 0; i < scan_of_track.size(); ++i) reordered.frames[j][scan_of_track[i]] = tracks.frames[j][i];
  }
  return reordered;
}

std::string DescribeDepartures(const std::vector<int>& scan_of_track) {
  std::string text;
  for (size_t i = 0; i < scan_of_track.size(); ++i) {
    if (scan_of_track[i] == static_cast<int>(i)) continue;
    text += (text.empty() ? "track " : ", track ") + std::to_string(i) + " follows scan fiducial " +
            std::to_string(scan_of_track[i]);
  }
  return text;
}

}  // namespace dg::stages
