#include "stages/register/phase_tracker.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>

#include "sim/error.h"

namespace dg::stages {
namespace {


double Wrapped(double phase) { return phase - std::floor(phase); }

}  // namespace

double CyclePhase(const std::vector<double>& starts_s, const std::vector<double>& periods_s, double tau_s) {
  DG_CHECK(!starts_s.empty() && starts_s.size() == periods_s.size() && tau_s >= starts_s.front());
  const size_t c = static_cast<size_t>(std::upper_bound(starts_s.begin(), starts_s.end(), tau_s) - starts_s.begin()) - 1;
  return Wrapped((tau_s - starts_s[c]) / periods_s[c]);
}

double PhaseDifference(double a, double b) { return Wrapped(a - b + 0.5) - 0.5; }

std::string PhaseTracker::Options::Validate() const {
  if (!(window_periods > 0 && window_periods <= 2)) return "window_periods must lie in (0, 2]";
  if (!(decay_periods > 0)) return "decay_periods must be positive";
  if (!(pixel_sigma > 0 && rate_sigma > 0 && amplitude_sigma > 0 && offset_sigma_m > 0)) {
    return "the sigmas must be positive";
  }
  if (iterations < 1) return "iterations must be at least 1";
  return {};
}

PhaseTracker::PhaseTracker(const Options& options, FiducialMotion scan, const Triangulator& geometry,
                           double period_s)
    : options_(options), scan_(std::move(scan)), geometry_(geometry), period_s_(period_s) {
  if (const std::string wrong = options_.Validate(); !wrong.empty()) {
    throw Error("invalid phase tracker options: " + wrong, "PhaseTracker::Options", "fix the option named");
  }
  if (const std::string wrong = scan_.Validate(); !wrong.empty()) {
    throw Error("invalid fiducial motion: " + wrong, "the scan's /phases/fiducials_S_m", "check the scan file");
  }
  if (!(period_s_ > 0)) {
    throw Error("the scan's period must be positive", "period_s", "give the scan's cardiac period in seconds");
  }
  // Cyclic finite-difference tangents (Catmull-Rom on the phases' own spacing):
  // the spline passes through every scan phase with a continuous slope, so
  // the fitted phase has no bias that changes from one segment to the next.
  const int P = scan_.num_phases();
  tangents_S_m_.resize(P);
  mean_S_m_ = Eigen::Matrix3Xd::Zero(3, scan_.num_fiducials());
  for (int k = 0; k < P; ++k) {
    const int before = (k + P - 1) % P, after = (k + 1) % P;
    double span = scan_.phases[after] - scan_.phases[before];
    if (span <= 0) span += 1;
    tangents_S_m_[k] = (scan_.positions_S_m[after] - scan_.positions_S_m[before]) / span;
    mean_S_m_ += scan_.positions_S_m[k] / P;
  }
}

Eigen::Vector3d PhaseTracker::ScanAt(int fiducial, double phi, Eigen::Vector3d* d_dphi) const {
  phi = Wrapped(phi);
  const int P = scan_.num_phases();
  int k = static_cast<int>(std::upper_bound(scan_.phases.begin(), scan_.phases.end(), phi) - scan_.phases.begin()) - 1;
  double start = 0;
  if (k < 0) {  // before the first phase: the wrapping segment from the last
    k = P - 1;
    start = scan_.phases[k] - 1;
  } else {
    start = scan_.phases[k];
  }
  const int next = (k + 1) % P;
  const double length = (next == 0 ? scan_.phases[0] + 1.0 : scan_.phases[next]) - scan_.phases[k];
  const double s = (phi - start) / length;
  const double s2 = s * s, s3 = s2 * s;
  const auto p0 = scan_.positions_S_m[k].col(fiducial), p1 = scan_.positions_S_m[next].col(fiducial);
  const Eigen::Vector3d m0 = length * tangents_S_m_[k].col(fiducial), m1 = length * tangents_S_m_[next].col(fiducial);
  if (d_dphi) {
    *d_dphi = ((6 * s2 - 6 * s) * p0 + (3 * s2 - 4 * s + 1) * m0 + (6 * s - 6 * s2) * p1 + (3 * s2 - 2 * s) * m1) /
              length;
  }
  return (2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * m0 + (3 * s2 - 2 * s3) * p1 + (s3 - s2) * m1;
}

Eigen::Vector3d PhaseTracker::Expected(int fiducial, double phi, double amplitude, const Eigen::Vector3d& offset_C_m,
                                       Eigen::Matrix<double, 3, 5>* d_dpAd) const {
  const Eigen::Vector3d mean = mean_S_m_.col(fiducial);
  Eigen::Vector3d d_dphi;
  const Eigen::Vector3d scan = ScanAt(fiducial, phi, d_dpAd ? &d_dphi : nullptr);
  const Eigen::Vector3d x_S = mean + amplitude * (scan - mean);
  Eigen::Matrix3d d_dX;
  const Eigen::Vector3d expected = geometry_.ToRectifiedDisparity(T_C_S_ * x_S + offset_C_m, d_dpAd ? &d_dX : nullptr);
  if (d_dpAd) {
    const Eigen::Matrix3d d_dX_S = d_dX * T_C_S_.linear();
    d_dpAd->col(0) = d_dX_S * (amplitude * d_dphi);
    d_dpAd->col(1) = d_dX_S * (scan - mean);
    d_dpAd->rightCols<3>() = d_dX;
  }
  return expected;
}

void PhaseTracker::Observe(double t_s, const std::vector<RectifiedSighting>& fiducials) {
  if (static_cast<int>(fiducials.size()) != scan_.num_fiducials()) {
    throw Error("the phase tracker got " + std::to_string(fiducials.size()) + " fiducials, the scan has " +
                    std::to_string(scan_.num_fiducials()),
                "PhaseTracker::Observe", "give one sighting per scan fiducial, in the scan's order");
  }
  if (!window_.empty() && !(t_s > window_.back().t_s)) {
    throw Error("frame times must increase", "PhaseTracker::Observe at t = " + std::to_string(t_s) + " s",
                "give frames in order");
  }
  // The oldest frame leaves its slot to the newest (no allocation once the window is full).
  const double oldest = t_s - options_.window_periods * period_s_;
  if (!window_.empty() && window_.front().t_s < oldest) {
    std::rotate(window_.begin(), window_.begin() + 1, window_.end());
    window_.back().t_s = t_s;
    window_.back().fiducials.assign(fiducials.begin(), fiducials.end());
    while (window_.front().t_s < oldest) window_.erase(window_.begin());
  } else {
    window_.push_back({t_s, fiducials});
  }
}

void PhaseTracker::Start(const Eigen::Isometry3d& T_C_S, double t_s, double phase, double rate_hz) {
  T_C_S_ = T_C_S;
  t_s_ = t_s;
  last_ = {phase, rate_hz, rate_hz, 1, Eigen::Vector3d::Zero()};
  started_ = true;
}

PhaseTracker::FramePhase PhaseTracker::PhaseOfAge(const Unknowns& x, double age_s) {
  // The current cycle began at the last whole phase c, (phi - c) / rate ago;
  // before that the previous cycle ran at its own rate.
  const double cycle = std::floor(x.phase);
  const double since_start_s = (x.phase - cycle) / x.rate_hz;
  if (age_s <= since_start_s) return {x.phase - x.rate_hz * age_s, 1, -age_s, 0};
  const double before_s = age_s - since_start_s;
  return {cycle - x.previous_rate_hz * before_s, x.previous_rate_hz / x.rate_hz,
          -x.previous_rate_hz * (x.phase - cycle) / (x.rate_hz * x.rate_hz), -before_s};
}

void PhaseTracker::Accumulate(const Unknowns& x, double now_s, Normal* normal) const {
  normal->matrix.setZero();
  normal->gradient.setZero();
  normal->weighted_squares = normal->weight_sum = 0;
  const double decay_s = options_.decay_periods * period_s_;
  const double inv_px2 = 1 / (options_.pixel_sigma * options_.pixel_sigma);
  const Eigen::Vector3d axis_weight(inv_px2, inv_px2, inv_px2 / 2);  // a disparity's error is two pixels'
  for (const Frame& frame : window_) {
    const double age = now_s - frame.t_s;
    const double w = std::exp(-age / decay_s);
    const FramePhase at = PhaseOfAge(x, age);
    for (size_t i = 0; i < frame.fiducials.size(); ++i) {
      if (!frame.fiducials[i].valid) continue;
      const int fiducial = static_cast<int>(i);
      Eigen::Matrix<double, 3, 5> d_dpAd;  // by the frame's phase, A and d
      const Eigen::Vector3d predicted = Expected(fiducial, at.phase, x.amplitude, x.offset_C_m, &d_dpAd);
      const Eigen::Vector3d residual = frame.fiducials[i].uvd_px - predicted;
      Eigen::Matrix<double, 3, kUnknowns> J;
      J.col(0) = d_dpAd.col(0) * at.d_phase;
      J.col(1) = d_dpAd.col(0) * at.d_rate;
      J.col(2) = d_dpAd.col(0) * at.d_previous_rate;
      J.rightCols<4>() = d_dpAd.rightCols<4>();
      const Eigen::Matrix<double, 3, kUnknowns> WJ = (w * axis_weight).asDiagonal() * J;
      normal->matrix += J.transpose() * WJ;
      normal->gradient += WJ.transpose() * residual;
      normal->weighted_squares += w * residual.cwiseProduct(residual).dot(axis_weight);
      normal->weight_sum += w * 3;
    }
  }
  // Priors: both rates near the scan's, the beat near its size, the offset near zero.
  const double nominal_rate = 1 / period_s_;
  const double rate_precision = 1 / std::pow(options_.rate_sigma * nominal_rate, 2);
  normal->matrix(1, 1) += rate_precision;
  normal->gradient(1) += rate_precision * (nominal_rate - x.rate_hz);
  normal->matrix(2, 2) += rate_precision;
  normal->gradient(2) += rate_precision * (nominal_rate - x.previous_rate_hz);
  const double amplitude_precision = 1 / std::pow(options_.amplitude_sigma, 2);
  normal->matrix(3, 3) += amplitude_precision;
  normal->gradient(3) += amplitude_precision * (1 - x.amplitude);
  const double offset_precision = 1 / std::pow(options_.offset_sigma_m, 2);
  for (int c = 0; c < 3; ++c) {
    normal->matrix(4 + c, 4 + c) += offset_precision;
    normal->gradient(4 + c) -= offset_precision * x.offset_C_m(c);
  }
}

PhaseEstimate PhaseTracker::Estimate() {
  PhaseEstimate estimate;
  if (!started_ || window_.empty()) return estimate;
  const double now = window_.back().t_s;
  // Carried forward at the last rate: the starting point, and the answer when the window is too thin.
  Unknowns x = last_;
  x.phase = last_.phase + last_.rate_hz * (now - t_s_);
  if (std::floor(x.phase) > std::floor(last_.phase)) x.previous_rate_hz = last_.rate_hz;  // a new cycle began
  estimate.valid = true;
  const int seen_frames = static_cast<int>(std::count_if(window_.begin(), window_.end(), [](const Frame& frame) {
    return std::any_of(frame.fiducials.begin(), frame.fiducials.end(),
                       [](const RectifiedSighting& s) { return s.valid; });
  }));
  if (seen_frames >= 3) {
    Normal normal;
    for (int iteration = 0; iteration < options_.iterations; ++iteration) {
      Accumulate(x, now, &normal);
      const Eigen::Matrix<double, kUnknowns, 1> step = normal.matrix.ldlt().solve(normal.gradient);
      if (!step.allFinite()) break;
      // A phase step beyond a tenth of a cycle is a jump to another branch of
      // the cycle, not a correction: bounded, as a trust region would.
      const double scale = std::min(1.0, 0.1 / std::max(std::abs(step(0)), 1e-12));
      x.phase += scale * step(0);
      x.rate_hz = std::max(0.2 / period_s_, x.rate_hz + scale * step(1));
      x.previous_rate_hz = std::max(0.2 / period_s_, x.previous_rate_hz + scale * step(2));
      x.amplitude += scale * step(3);
      x.offset_C_m += scale * step.tail<3>();
    }
    Accumulate(x, now, &normal);
    // The fit's covariance, scaled up when the residuals exceed the assumed pixel error.
    const double variance_scale = std::max(1.0, normal.weighted_squares / std::max(normal.weight_sum, 1e-12));
    const Eigen::Matrix<double, kUnknowns, kUnknowns> covariance =
        normal.matrix.ldlt().solve(Eigen::Matrix<double, kUnknowns, kUnknowns>::Identity());
    estimate.sigma = std::sqrt(std::max(0.0, covariance(0, 0)) * variance_scale);
  } else {
    estimate.sigma = std::numeric_limits<double>::infinity();
  }
  t_s_ = now;
  last_ = x;
  estimate.phase = Wrapped(x.phase);
  estimate.rate_hz = x.rate_hz;
  estimate.amplitude = x.amplitude;
  return estimate;
}

}  // namespace dg::stages
