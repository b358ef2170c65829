#include "stages/constraints/gap_targets.h"

#include <algorithm>
#include <cmath>

#include "sim/error.h"

namespace dg::stages {

GapTargets::GapTargets(std::shared_ptr<const sim::CyclicMotionModel> predictor, double phase_at_zero)
    : predictor_(std::move(predictor)),
      anchor_phase_(phase_at_zero),
      rate_hz_(predictor_ ? 1 / predictor_->period_s() : 0) {}

void GapTargets::FollowPhase(double t_s, double phase, double rate_hz) {
  anchor_t_s_ = t_s;
  anchor_phase_ = phase;
  rate_hz_ = rate_hz;
}

void GapTargets::Predict(int node, double t_s, double* out) const {
  const double phase = anchor_phase_ + rate_hz_ * (t_s - anchor_t_s_);
  predictor_->Evaluate<double>(phase, 3 * node, std::span<double>(out, 3));
}

void GapTargets::ObserveSpeed(const NodeTargets& targets, double elapsed_s) {
  // Both node lists increase: one merge walk finds the nodes tracked at both frames.
  size_t p = 0;
  for (size_t k = 0; elapsed_s > 0 && k < targets.nodes.size(); ++k) {
    while (p < previous_nodes_.size() && previous_nodes_[p] < targets.nodes[k]) ++p;
    if (p == previous_nodes_.size()) break;
    if (previous_nodes_[p] != targets.nodes[k]) continue;
    double squared = 0;
    for (int i = 0; i < 3; ++i) {
      const double d = targets.displacement_S_m[3 * k + i] - previous_target_m_[3 * p + i];
      squared += d * d;
    }
    speed_limit_m_per_s_ = std::max(speed_limit_m_per_s_, std::sqrt(squared) / elapsed_s);
  }
  previous_nodes_ = targets.nodes;
  previous_target_m_ = targets.displacement_S_m;
}

void GapTargets::Begin(const NodeTargets& targets, std::span<const double> start_m, double from_s, double to_s) {
  DG_CHECK(start_m.size() == 3 * targets.nodes.size() && targets.displacement_S_m.size() == start_m.size());
  DG_CHECK(from_s <= to_s);
  from_s_ = from_s;
  to_s_ = to_s;
  nodes_ = targets.nodes;
  start_m_.assign(start_m.begin(), start_m.end());
  target_m_ = targets.displacement_S_m;
  if (!predictor_) {
    ObserveSpeed(targets, to_s - from_s);
    return;
  }
  residual_from_m_.resize(start_m_.size());
  residual_to_m_.resize(start_m_.size());
  for (size_t k = 0; k < nodes_.size(); ++k) {
    double from[3], to[3];
    Predict(nodes_[k], from_s, from);
    Predict(nodes_[k], to_s, to);
    for (int i = 0; i < 3; ++i) {
      residual_from_m_[3 * k + i] = start_m_[3 * k + i] - from[i];
      residual_to_m_[3 * k + i] = target_m_[3 * k + i] - to[i];
    }
  }
}

void GapTargets::At(double t_s, std::vector<double>* out) const {
  if (predictor_ && t_s >= to_s_) {  // the frame's own targets, exactly
    *out = target_m_;
    return;
  }
  out->resize(target_m_.size());
  const double elapsed_s = std::min(t_s, to_s_) - from_s_;
  for (size_t k = 0; k < nodes_.size(); ++k) {
    double* target = out->data() + 3 * k;
    if (predictor_) {
      const double fraction = elapsed_s / (to_s_ - from_s_);
      Predict(nodes_[k], t_s, target);
      for (int i = 0; i < 3; ++i) {
        target[i] += residual_from_m_[3 * k + i] + fraction * (residual_to_m_[3 * k + i] - residual_from_m_[3 * k + i]);
      }
      continue;
    }
    double way[3], length = 0;
    for (int i = 0; i < 3; ++i) {
      way[i] = target_m_[3 * k + i] - start_m_[3 * k + i];
      length += way[i] * way[i];
    }
    length = std::sqrt(length);
    const double reach = speed_limit_m_per_s_ * elapsed_s;
    const double fraction = length > reach ? reach / length : 1.0;
    for (int i = 0; i < 3; ++i) target[i] = start_m_[3 * k + i] + fraction * way[i];
  }
}

}  // namespace dg::stages
