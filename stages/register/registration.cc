#include "stages/register/registration.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include <ceres/ceres.h>
#include <fmt/format.h>
#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <tbb/parallel_for.h>

#include "io/h5_file.h"
#include "sim/error.h"
#include "sim/log.h"
#include "stages/register/reprojection_residual.h"

namespace dg::stages {
namespace {

constexpr const char* kWhere = "registration";

// Enough for 0.999 confidence of one clean 5-point sample with a third of the
// sightings gross outliers: (1 - 0.67^5)^50 < 1e-3. Wrong shifts have few
// inliers and would otherwise spend OpenCV's full default budget.
constexpr int kRansacIterations = 50;

// Blocks of the window the jackknife leaves out in turn: each solution keeps
// five sixths of it (two and a half of the default three cycles).
constexpr int kJackknifeBlocks = 6;

std::string Px(double px) { return fmt::format("{:.2f}", px); }
std::string Percent(double fraction) { return fmt::format("{:.0f}%", 100 * fraction); }

// One sighting in one eye.
struct Observation {
  int fiducial;
  int eye;  // 0 left, 1 right
  double t_s;
  Eigen::Vector2d uv_px;
};

// The seven parameters, in the blocks Ceres sees.
struct Pose {
  double rotation[3] = {0, 0, 0};  // angle-axis of R_C_S
  double translation_m[3] = {0, 0, 0};
  double shift_s = 0;
};

struct Problem {
  const FiducialMotion& motion;
  double period_s;
  std::array<EyeModel, 2> eyes;
  std::vector<Observation> observations;

  ReprojectionResidual Residual(const Observation& o) const {
    return {&motion, &eyes[o.eye], o.fiducial, o.t_s, period_s, o.uv_px};
  }
  // Squared pixel error of one observation; infinite behind the eye.
  double SquaredError(const Observation& o, const Pose& pose) const {
    double r[2];
    if (!Residual(o)(pose.rotation, pose.translation_m, &pose.shift_s, r)) return std::numeric_limits<double>::infinity();
    return r[0] * r[0] + r[1] * r[1];
  }
};

std::vector<Observation> Flatten(const FiducialTracks& tracks) {
  std::vector<Observation> observations;
  for (size_t j = 0; j < tracks.frames.size(); ++j) {
    for (size_t i = 0; i < tracks.frames[j].size(); ++i) {
      const FiducialSighting& s = tracks.frames[j][i];
      if (s.in_left) observations.push_back({int(i), 0, tracks.t_s[j], s.uv_left_px});
      if (s.in_right) observations.push_back({int(i), 1, tracks.t_s[j], s.uv_right_px});
    }
  }
  return observations;
}

void CheckInput(const FiducialMotion& motion, double period_s, const FiducialTracks& tracks,
                const RegistrationOptions& options) {
  if (const std::string wrong = options.Validate(); !wrong.empty()) {
    throw Error("invalid registration options: " + wrong, kWhere, "correct the option");
  }
  if (const std::string wrong = motion.Validate(); !wrong.empty()) {
    throw Error("invalid fiducial motion: " + wrong, kWhere, "check the scan's fiducial positions");
  }
  const int F = motion.num_fiducials();
  if (F < 3) {
    throw Error("the scan gives " + std::to_string(F) + " fiducials; registration needs at least 3", kWhere,
                "mark at least 3 (the paper uses 5) fiducials in the scan");
  }
  if (!(period_s > 0)) throw Error("the cardiac period must be positive", kWhere, "give the scan's period_s");
  if (tracks.t_s.size() != tracks.frames.size() || tracks.t_s.size() < 2) {
    throw Error("the window holds " + std::to_string(tracks.frames.size()) + " frames with " +
                    std::to_string(tracks.t_s.size()) + " times",
                kWhere, "give one time per frame, at least two frames");
  }
  std::vector<int> seen_left(F, 0), seen_right(F, 0);
  for (size_t j = 0; j < tracks.frames.size(); ++j) {
    if (static_cast<int>(tracks.frames[j].size()) != F) {
      throw Error("frame " + std::to_string(j) + " has " + std::to_string(tracks.frames[j].size()) +
                      " fiducial sightings but the scan has " + std::to_string(F) + " fiducials",
                  kWhere, "track the scan's fiducials, in the scan's order, in every frame (unseen ones marked so)");
    }
    if (j > 0 && !(tracks.t_s[j] > tracks.t_s[j - 1])) {
      throw Error("frame times must increase (frame " + std::to_string(j) + ")", kWhere, "give the frames in order");
    }
    for (int i = 0; i < F; ++i) {
      seen_left[i] += tracks.frames[j][i].in_left;
      seen_right[i] += tracks.frames[j][i].in_right;
    }
  }
  // The window covers [t_0, t_last + one frame interval).
  const double frame_s = (tracks.t_s.back() - tracks.t_s.front()) / double(tracks.t_s.size() - 1);
  const double window_s = tracks.t_s.back() - tracks.t_s.front() + frame_s;
  if (window_s < period_s * (1 - 1e-6)) {
    throw Error("the window of " + std::to_string(1e3 * window_s) + " ms is shorter than one cardiac cycle (" +
                    std::to_string(1e3 * period_s) + " ms)",
                kWhere, "register over at least one whole cycle (the paper's premise: several are better)");
  }
  for (int i = 0; i < F; ++i) {
    for (const auto& [seen, eye] : {std::pair{&seen_left, "left"}, std::pair{&seen_right, "right"}}) {
      if ((*seen)[i] == 0) {
        throw Error("fiducial " + std::to_string(i) + " is never seen in the " + eye + " video", kWhere,
                    "check its tracking (its first-frame position), or leave it out of the scan's fiducials");
      }
    }
  }
}

// The Cauchy loss on a squared error, as Ceres applies it.
double RobustCost(const Problem& problem, const Pose& pose, double scale_px) {
  const double b = scale_px * scale_px;
  double cost = 0;
  for (const Observation& o : problem.observations) cost += b * std::log1p(problem.SquaredError(o, pose) / b);
  return 0.5 * cost;
}

// The pose at a given shift from the left view alone: RANSAC over EPnP, then
// Levenberg-Marquardt on the consensus (OpenCV, with the full distortion model).
bool InitialPose(const Problem& problem, const io::CameraCalibration& left, double outlier_px, Pose* pose) {
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (const Observation& o : problem.observations) {
    if (o.eye != 0) continue;
    double xyz[3];
    FiducialAtPhase(problem.motion, o.fiducial, (o.t_s + pose->shift_s) / problem.period_s, xyz);
    object.emplace_back(xyz[0], xyz[1], xyz[2]);
    image.emplace_back(o.uv_px.x(), o.uv_px.y());
  }
  if (object.size() < 6) return false;
  cv::Mat K, D(1, 8, CV_64F, const_cast<double*>(left.distortion.data())), rvec, tvec;
  cv::eigen2cv(left.K, K);
  std::vector<int> inliers;
  if (!cv::solvePnPRansac(object, image, K, D, rvec, tvec, false, kRansacIterations, float(outlier_px), 0.999, inliers,
                          cv::SOLVEPNP_EPNP) ||
      inliers.size() < 6) {
    return false;
  }
  std::vector<cv::Point3d> object_in;
  std::vector<cv::Point2d> image_in;
  for (int k : inliers) {
    object_in.push_back(object[k]);
    image_in.push_back(image[k]);
  }
  cv::solvePnPRefineLM(object_in, image_in, K, D, rvec, tvec);
  for (int k = 0; k < 3; ++k) {
    pose->rotation[k] = rvec.at<double>(k);
    pose->translation_m[k] = tvec.at<double>(k);
  }
  return true;
}

// The candidates to refine: the cyclic profile's local minima, best first.
std::vector<int> BestMinima(const std::vector<double>& cost, int count) {
  const int n = static_cast<int>(cost.size());
  std::vector<int> minima;
  for (int c = 0; c < n; ++c) {
    if (std::isfinite(cost[c]) && cost[c] <= cost[(c + n - 1) % n] && cost[c] <= cost[(c + 1) % n]) minima.push_back(c);
  }
  std::sort(minima.begin(), minima.end(), [&](int a, int b) { return cost[a] < cost[b]; });
  if (static_cast<int>(minima.size()) > count) minima.resize(count);
  return minima;
}

struct Refined {
  Pose pose;
  double cost = std::numeric_limits<double>::infinity();
  int iterations = 0;
};

// Every observation's residual on the pose's three parameter blocks, under one Cauchy loss.
void AddResiduals(const Problem& problem, ceres::LossFunction* loss, Pose* pose, ceres::Problem* ceres_problem) {
  for (const Observation& o : problem.observations) {
    ceres_problem->AddResidualBlock(
        new ceres::AutoDiffCostFunction<ReprojectionResidual, 2, 3, 3, 1>(new ReprojectionResidual(problem.Residual(o))),
        loss, pose->rotation, pose->translation_m, &pose->shift_s);
  }
}

ceres::Problem::Options ProblemOptions() {
  ceres::Problem::Options options;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return options;
}

// Joint Levenberg-Marquardt over rotation, translation and shift with a Cauchy loss.
Refined Refine(const Problem& problem, const Pose& start, const RegistrationOptions& options) {
  Refined refined;
  refined.pose = start;
  ceres::Problem ceres_problem(ProblemOptions());
  ceres::CauchyLoss loss(options.robust_scale_px);
  AddResiduals(problem, &loss, &refined.pose, &ceres_problem);
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.logging_type = ceres::SILENT;
  solver_options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &ceres_problem, &summary);
  if (summary.IsSolutionUsable()) {
    refined.cost = summary.final_cost;
    refined.iterations = static_cast<int>(summary.iterations.size());
  }
  return refined;
}

// Ceres' covariance of the seven parameters at the optimum (for unit-variance
// residuals; NaN where the problem is rank deficient).
Eigen::Matrix<double, 7, 7> UnitCovariance(const Problem& problem, Pose pose, const RegistrationOptions& options) {
  ceres::Problem ceres_problem(ProblemOptions());
  ceres::CauchyLoss loss(options.robust_scale_px);
  AddResiduals(problem, &loss, &pose, &ceres_problem);
  ceres::Covariance::Options covariance_options;
  covariance_options.num_threads = 1;
  ceres::Covariance covariance(covariance_options);
  const std::vector<const double*> blocks = {pose.rotation, pose.translation_m, &pose.shift_s};
  std::vector<std::pair<const double*, const double*>> pairs;
  for (size_t a = 0; a < blocks.size(); ++a) {
    for (size_t b = a; b < blocks.size(); ++b) pairs.emplace_back(blocks[a], blocks[b]);
  }
  Eigen::Matrix<double, 7, 7, Eigen::RowMajor> c = Eigen::Matrix<double, 7, 7, Eigen::RowMajor>::Constant(std::nan(""));
  if (covariance.Compute(pairs, &ceres_problem)) covariance.GetCovarianceMatrix(blocks, c.data());
  return c;
}

io::ReprojectionStats Statistics(const Problem& problem, const Pose& pose, int eye, double outlier_px) {
  io::ReprojectionStats s;
  const EyeModel& model = problem.eyes[eye];
  const double focal_px = 0.5 * (model.intrinsics[0] + model.intrinsics[1]);
  double sum_px2 = 0, sum_mm2 = 0;
  for (const Observation& o : problem.observations) {
    if (o.eye != eye) continue;
    const double error_px = std::sqrt(problem.SquaredError(o, pose));
    if (!(error_px <= outlier_px)) {
      ++s.outliers;
      continue;
    }
    // The fiducial's depth in this eye at the registered pose.
    double xyz_S[3], xyz_C[3];
    FiducialAtPhase(problem.motion, o.fiducial, (o.t_s + pose.shift_s) / problem.period_s, xyz_S);
    ceres::AngleAxisRotatePoint(pose.rotation, xyz_S, xyz_C);
    const Eigen::Vector3d x_C = Eigen::Map<Eigen::Vector3d>(xyz_C) + Eigen::Map<const Eigen::Vector3d>(pose.translation_m);
    const double depth_m = (model.R_E_C * x_C + model.t_E_C_m).z();
    const double error_mm = 1e3 * error_px * depth_m / focal_px;
    ++s.observations;
    s.mean_px += error_px;
    s.mean_mm += error_mm;
    s.max_px = std::max(s.max_px, error_px);
    s.max_mm = std::max(s.max_mm, error_mm);
    sum_px2 += error_px * error_px;
    sum_mm2 += error_mm * error_mm;
  }
  if (s.observations > 0) {
    s.mean_px /= s.observations;
    s.mean_mm /= s.observations;
    s.rms_px = std::sqrt(sum_px2 / s.observations);
    s.rms_mm = std::sqrt(sum_mm2 / s.observations);
  }
  return s;
}

// The assignment of tracks to scan fiducials that explains the tracks (said
// when it is not the order given), or a refusal naming why there is none.
FiducialAssignment ChooseAssignment(const FiducialMotion& motion, const io::StereoCalibration& calibration,
                                    const FiducialTracks& tracks, const RegistrationOptions& options) {
  FiducialAssignment assignment = AssignFiducials(motion, calibration, tracks, options.assignment_tolerance_px);
  const std::string tolerance = Px(options.assignment_tolerance_px);
  switch (assignment.verdict) {
    case FiducialAssignment::Verdict::kGiven:
      break;
    case FiducialAssignment::Verdict::kReassigned:
      Logger("stages").warn(
          "registration: the first-frame pixels are not in the scan's fiducial order: {} (their mean positions fit "
          "the scan's to {} px in that order, {} px in the order given); registering with the order that fits",
          DescribeDepartures(assignment.scan_of_track), Px(assignment.rms_px), Px(assignment.given_rms_px));
      break;
    case FiducialAssignment::Verdict::kNoneFits: {
      const std::vector<double>& departure = assignment.track_departure_px;
      const auto worst = std::max_element(departure.begin(), departure.end());
      throw Error("the tracked markers fit the scan's fiducials in no order: their mean positions are " +
                      Px(assignment.rms_px) + " px rms from the scan's under the best pose (at most " + tolerance +
                      " px)" +
                      (*worst > 0 ? ", and track " + std::to_string(worst - departure.begin()) + " departs " +
                                        Px(*worst) + " px from the pose the others fit"
                                  : std::string()),
                  kWhere,
                  "check the first-frame fiducial pixels (registration.fiducials_uv): each must be on its marker's "
                  "centre, not beside it; and that the calibration is this endoscope's");
    }
    case FiducialAssignment::Verdict::kAmbiguous:
      throw Error("the first-frame pixels are not in the scan's fiducial order (a fit of " +
                      Px(assignment.given_rms_px) + " px, at most " + tolerance +
                      " px wanted), and more than one other order fits (" + Px(assignment.rms_px) + " and " +
                      Px(assignment.runner_up_rms_px) + " px)",
                  kWhere,
                  "give the pixels in the scan's fiducial order (registration.fiducials_uv): the markers are placed "
                  "too symmetrically to tell apart by their layout");
  }
  return assignment;
}

// Whether two solutions are different minima rather than one reached twice.
bool Distinct(const Pose& a, const Pose& b, double period_s, int phases) {
  const Eigen::Vector3d ra = Eigen::Map<const Eigen::Vector3d>(a.rotation), rb = Eigen::Map<const Eigen::Vector3d>(b.rotation);
  const auto rotation = [](const Eigen::Vector3d& v) {
    return v.norm() > 0 ? Eigen::AngleAxisd(v.norm(), v.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
  };
  const double angle_rad = Eigen::AngleAxisd(rotation(ra).transpose() * rotation(rb)).angle();
  const double translation_m =
      (Eigen::Map<const Eigen::Vector3d>(a.translation_m) - Eigen::Map<const Eigen::Vector3d>(b.translation_m)).norm();
  const double shift = a.shift_s - b.shift_s;
  const double shift_s = std::abs(shift - period_s * std::round(shift / period_s));
  return angle_rad > 1.0 * M_PI / 180 || translation_m > 1e-3 || shift_s > 0.5 * period_s / phases;
}

// The window's frames in `blocks` consecutive blocks by time; the jackknife
// leaves each out in turn.
int BlockOf(double t_s, double t0_s, double window_s, int blocks) {
  return std::min(blocks - 1, static_cast<int>(std::floor((t_s - t0_s) / window_s * blocks)));
}

// Ceres' covariance assumes independent residuals. The window's are not: a
// beat that departs from the scan's motion (a longer period, a deeper
// breath) leaves errors correlated over whole cycles, and the covariance
// then claims far more than the window holds. The delete-a-block jackknife
// over consecutive blocks of the window sees that departure as spread
// between the blocks' solutions. Each parameter's variance is raised to the
// jackknife's where that is larger (a congruence: the matrix stays positive
// semi-definite and keeps Ceres' correlations).
Eigen::Matrix<double, 7, 7> JackknifeInflated(const Problem& problem, const Pose& best, const Eigen::Matrix<double, 7, 7>& covariance,
                                              double t0_s, double window_s, const RegistrationOptions& options) {
  const int blocks = kJackknifeBlocks;
  std::vector<Refined> solutions(blocks);
  tbb::parallel_for(0, blocks, [&](int b) {
    Problem without{problem.motion, problem.period_s, problem.eyes, {}};
    for (const Observation& o : problem.observations) {
      if (BlockOf(o.t_s, t0_s, window_s, blocks) != b) without.observations.push_back(o);
    }
    solutions[b] = Refine(without, best, options);
  });
  Eigen::Matrix<double, 7, Eigen::Dynamic> theta(7, blocks);
  for (int b = 0; b < blocks; ++b) {
    if (!std::isfinite(solutions[b].cost)) return covariance;  // a block the window cannot spare: Ceres' alone
    const Pose& p = solutions[b].pose;
    theta.col(b) << p.rotation[0], p.rotation[1], p.rotation[2], p.translation_m[0], p.translation_m[1],
        p.translation_m[2], p.shift_s;
  }
  const Eigen::Matrix<double, 7, Eigen::Dynamic> centred = theta.colwise() - theta.rowwise().mean();
  const Eigen::Matrix<double, 7, 7> jackknife = (blocks - 1.0) / blocks * centred * centred.transpose();
  Eigen::Matrix<double, 7, 1> scale;
  for (int i = 0; i < 7; ++i) scale[i] = std::sqrt(std::max(1.0, jackknife(i, i) / covariance(i, i)));
  return scale.asDiagonal() * covariance * scale.asDiagonal();
}

// Refuses a solution the tracks do not support, naming the figure and the likely cause.
void CheckSolution(const RegistrationResult& result, const RegistrationOptions& options) {
  const io::Registration& r = result.registration;
  const int kept = r.left.observations + r.right.observations;
  const int outliers = r.left.outliers + r.right.outliers;
  const double outlier_fraction = double(outliers) / std::max(1, kept + outliers);
  const char* tracks_fix =
      "check the first-frame fiducial pixels (registration.fiducials_uv): each must be on its marker, in the scan's "
      "fiducial order; and that the calibration is this endoscope's";
  if (outlier_fraction > options.max_outlier_fraction) {
    throw Error("the registration leaves " + std::to_string(outliers) + " of " + std::to_string(kept + outliers) +
                    " fiducial sightings over " + Px(options.outlier_px) + " px from the scan's motion (at most " +
                    Percent(options.max_outlier_fraction) + " allowed): the tracks do not follow the scan's fiducials",
                kWhere, tracks_fix);
  }
  const double rms_px = std::max(r.left.rms_px, r.right.rms_px);
  if (rms_px > options.max_rms_px) {
    throw Error("the registration's residuals are " + Px(rms_px) + " px rms (at most " + Px(options.max_rms_px) +
                    " px for tracked markers): the scan's motion does not explain the tracks",
                kWhere, tracks_fix);
  }
  if (result.runner_up_cost_ratio < options.min_runner_up_ratio) {
    throw Error("the registration is not unique: another pose and phase shift explain the tracks nearly as well (cost " +
                    Px(result.runner_up_cost_ratio) + " times the best's, at least " +
                    Px(options.min_runner_up_ratio) + " wanted)",
                kWhere, "register over more cycles (registration.cycles), or mark more fiducials spread over the surface");
  }
}

}  // namespace

std::string RegistrationOptions::Validate() const {
  if (search_steps_per_phase < 1) return "search_steps_per_phase must be at least 1";
  if (refined_candidates < 1) return "refined_candidates must be at least 1";
  if (!(robust_scale_px > 0)) return "robust_scale_px must be positive";
  if (!(outlier_px > robust_scale_px)) return "outlier_px must exceed robust_scale_px";
  if (max_iterations < 1) return "max_iterations must be at least 1";
  if (!(assignment_tolerance_px > 0)) return "assignment_tolerance_px must be positive";
  if (!(max_rms_px > 0)) return "max_rms_px must be positive";
  if (!(max_outlier_fraction >= 0 && max_outlier_fraction < 1)) return "max_outlier_fraction must lie in [0, 1)";
  if (!(min_runner_up_ratio >= 1)) return "min_runner_up_ratio must be at least 1";
  return {};
}

RegistrationResult RegisterScanToVideo(const FiducialMotion& motion, const io::StereoCalibration& calibration,
                                       double period_s, const FiducialTracks& tracks,
                                       const RegistrationOptions& options) {
  CheckInput(motion, period_s, tracks, options);
  RegistrationResult result;
  result.assignment = ChooseAssignment(motion, calibration, tracks, options);
  const Problem problem{motion, period_s, {EyeModel::Left(calibration), EyeModel::Right(calibration)},
                        Flatten(Reordered(tracks, result.assignment.scan_of_track))};

  // Global search over one period: the cost has a basin per phase-sized step.
  const int n = options.search_steps_per_phase * motion.num_phases();
  result.search_shift_s.resize(n);
  result.search_cost.assign(n, std::numeric_limits<double>::infinity());
  std::vector<Pose> starts(n);
  tbb::parallel_for(0, n, [&](int c) {
    starts[c].shift_s = result.search_shift_s[c] = period_s * c / n;
    if (InitialPose(problem, calibration.left, options.outlier_px, &starts[c])) {
      result.search_cost[c] = RobustCost(problem, starts[c], options.robust_scale_px);
    }
  });
  const std::vector<int> candidates = BestMinima(result.search_cost, options.refined_candidates);
  if (candidates.empty()) {
    throw Error("no phase shift gave a camera pose (PnP failed at every candidate)", kWhere,
                "check that the fiducials' tracks and the scan's fiducials are the same markers in the same order");
  }

  std::vector<Refined> refined(candidates.size());
  tbb::parallel_for(0, static_cast<int>(candidates.size()),
                    [&](int k) { refined[k] = Refine(problem, starts[candidates[k]], options); });
  const Refined& best = *std::min_element(refined.begin(), refined.end(),
                                          [](const Refined& a, const Refined& b) { return a.cost < b.cost; });
  if (!std::isfinite(best.cost)) {
    throw Error("the joint refinement failed from every candidate", kWhere,
                "check the calibration and that the tracks follow the scan's fiducials");
  }
  result.runner_up_cost_ratio = std::numeric_limits<double>::infinity();
  for (const Refined& other : refined) {
    if (std::isfinite(other.cost) && Distinct(other.pose, best.pose, period_s, motion.num_phases())) {
      result.runner_up_cost_ratio = std::min(result.runner_up_cost_ratio, other.cost / best.cost);
    }
  }

  io::Registration& r = result.registration;
  Eigen::Isometry3d T_C_S = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d rotation = Eigen::Map<const Eigen::Vector3d>(best.pose.rotation);
  if (rotation.norm() > 0) T_C_S.linear() = Eigen::AngleAxisd(rotation.norm(), rotation.normalized()).toRotationMatrix();
  T_C_S.translation() = Eigen::Map<const Eigen::Vector3d>(best.pose.translation_m);
  r.T_C_S = T_C_S.matrix();
  r.period_s = period_s;
  r.phase_shift_s = best.pose.shift_s - period_s * std::floor(best.pose.shift_s / period_s);
  const double frame_s = (tracks.t_s.back() - tracks.t_s.front()) / double(tracks.t_s.size() - 1);
  const double window_s = tracks.t_s.back() - tracks.t_s.front() + frame_s;
  r.cycles = window_s / period_s;
  r.left = Statistics(problem, best.pose, 0, options.outlier_px);
  r.right = Statistics(problem, best.pose, 1, options.outlier_px);
  // Ceres' covariance is (J^T J)^-1 for unit-variance residuals: scaled by the
  // kept residuals' variance per coordinate, sum r^2 / (2 m - 7).
  const int kept = r.left.observations + r.right.observations;
  const double variance_px2 =
      (r.left.rms_px * r.left.rms_px * r.left.observations + r.right.rms_px * r.right.rms_px * r.right.observations) /
      std::max(1, 2 * kept - 7);
  r.covariance = UnitCovariance(problem, best.pose, options) * variance_px2;
  if (!r.covariance.allFinite()) {
    Logger("stages").warn("registration: the covariance is rank deficient (too few distinct fiducial positions?)");
  } else {
    r.covariance = JackknifeInflated(problem, best.pose, r.covariance, tracks.t_s.front(), window_s, options);
  }
  result.iterations = best.iterations;
  CheckSolution(result, options);
  return result;
}

void WriteRegistrationLog(const RegistrationResult& result, io::H5Writer* file, const std::string& group) {
  io::WriteRegistrationH5(file, group, result.registration);
  const io::H5Shape shape = {result.search_shift_s.size()};
  file->Write(group + "/search/shift_s", result.search_shift_s.data(), shape);
  file->Write(group + "/search/cost_px2", result.search_cost.data(), shape);
  const std::vector<std::int32_t> scan_of_track(result.assignment.scan_of_track.begin(),
                                                result.assignment.scan_of_track.end());
  file->Write(group + "/assignment/scan_fiducial_of_track", scan_of_track.data(), {scan_of_track.size()});
  file->WriteScalar(group + "/assignment/fit_rms_px", result.assignment.rms_px);
  file->WriteScalar(group + "/assignment/given_order_rms_px", result.assignment.given_rms_px);
  file->WriteScalar(group + "/runner_up_cost_ratio", result.runner_up_cost_ratio);
}

}  // namespace dg::stages
