#include "stages/track/stereo_matcher.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include "sim/error.h"

namespace dg::stages {
namespace {

// Zero mean, unit norm: the window's NCC with another is then a dot product.
bool Normalize(cv::Mat* window) {
  const cv::Scalar mean = cv::mean(*window);
  *window -= mean;
  const double norm = cv::norm(*window);
  if (norm < 1e-6) return false;
  *window /= norm;
  return true;
}

// Keys' cubic convolution weights (a = -0.75, as OpenCV's INTER_CUBIC) of the
// four taps at -1, 0, 1, 2 for a sample at fraction t in [0, 1).
std::array<float, 4> CubicWeights(float t) {
  constexpr float a = -0.75f;
  const float s = 1 - t;
  const float w0 = ((a * (t + 1) - 5 * a) * (t + 1) + 8 * a) * (t + 1) - 4 * a;
  const float w1 = ((a + 2) * t - (a + 3)) * t * t + 1;
  const float w2 = ((a + 2) * s - (a + 3)) * s * s + 1;
  return {w0, w1, w2, 1 - w0 - w1 - w2};
}

// Bicubic windows of one size at sub-pixel centres, from a float copy of an
// image neighbourhood made once: bilinear sampling (getRectSubPix) smooths
// differently at each fraction of a pixel and biases the sub-pixel estimate by
// a few hundredths of a pixel; an 8-bit result would be rounded to whole grey
// levels. Every pixel of a window has the same fractions, so the kernel is one
// set of separable weights, computed exactly (cv::remap rounds them to 1/32 px).
// Pixels beyond the image repeat its edge. Sampling allocates nothing.
class CubicSampler {
 public:
  // Windows of `size` centred within `reach` px of `centre` along x.
  CubicSampler(const cv::Mat& image, cv::Size size, const cv::Point2f& centre, int reach)
      : size_(size), window_(size, CV_32F), rows_(size.width, 0.0f) {
    const cv::Point2f origin = Origin(centre);
    // Two pixels either side for the cubic's support.
    const cv::Rect wanted(static_cast<int>(std::floor(origin.x)) - 2 - reach,
                          static_cast<int>(std::floor(origin.y)) - 2, size.width + 5 + 2 * reach, size.height + 5);
    roi_ = wanted & cv::Rect(0, 0, image.cols, image.rows);
    image(roi_).convertTo(patch_, CV_32F);
  }

  // The window centred at `centre`; valid until the next call.
  const cv::Mat& Sample(const cv::Point2f& centre) {
    const cv::Point2f origin = Origin(centre) - cv::Point2f(static_cast<float>(roi_.x), static_cast<float>(roi_.y));
    const int x0 = static_cast<int>(std::floor(origin.x)), y0 = static_cast<int>(std::floor(origin.y));
    const std::array<float, 4> wx = CubicWeights(origin.x - static_cast<float>(x0));
    const std::array<float, 4> wy = CubicWeights(origin.y - static_cast<float>(y0));
    const auto clamp_x = [&](int x) { return std::clamp(x, 0, patch_.cols - 1); };
    const auto clamp_y = [&](int y) { return std::clamp(y, 0, patch_.rows - 1); };
    for (int r = 0; r < size_.height; ++r) {
      std::fill(rows_.begin(), rows_.end(), 0.0f);
      // Each of the four source rows filtered along x, then summed with the weights along y.
      for (int j = 0; j < 4; ++j) {
        const float* in = patch_.ptr<float>(clamp_y(y0 + r + j - 1));
        for (int c = 0; c < size_.width; ++c) {
          float sum = 0;
          for (int i = 0; i < 4; ++i) sum += wx[i] * in[clamp_x(x0 + c + i - 1)];
          rows_[c] += wy[j] * sum;
        }
      }
      std::copy(rows_.begin(), rows_.end(), window_.ptr<float>(r));
    }
    return window_;
  }

 private:
  cv::Point2f Origin(const cv::Point2f& centre) const {
    return {centre.x - 0.5f * static_cast<float>(size_.width - 1), centre.y - 0.5f * static_cast<float>(size_.height - 1)};
  }

  cv::Size size_;
  cv::Rect roi_;
  cv::Mat patch_, window_;
  std::vector<float> rows_;
};

// cv::matchTemplate's TM_CCOEFF_NORMED of a one-row result, summed directly:
// for windows this small OpenCV's general path costs more than the sums.
// A flat strip window (no texture) scores 0.
void NormalizedCrossCorrelation(const cv::Mat& strip, const cv::Mat& window, cv::Mat* ncc) {
  const int w = window.cols, h = window.rows, count = strip.cols - w + 1;
  const double n = static_cast<double>(w * h);
  double window_sum = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) window_sum += window.at<float>(y, x);
  const double window_mean = window_sum / n;
  double window_norm2 = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) window_norm2 += std::pow(window.at<float>(y, x) - window_mean, 2);
  ncc->create(1, count, CV_32F);
  float* out = ncc->ptr<float>(0);
  for (int j = 0; j < count; ++j) {
    double sum = 0, sum2 = 0, cross = 0;
    for (int y = 0; y < h; ++y) {
      const float* s = strip.ptr<float>(y) + j;
      const float* t = window.ptr<float>(y);
      for (int x = 0; x < w; ++x) {
        sum += s[x];
        sum2 += double(s[x]) * s[x];
        cross += (t[x] - window_mean) * s[x];  // the window's zero mean removes the strip's mean
      }
    }
    const double strip_norm2 = std::max(0.0, sum2 - sum * sum / n);
    const double denominator = std::sqrt(strip_norm2 * window_norm2);
    out[j] = denominator > 1e-6 ? static_cast<float>(cross / denominator) : 0.0f;
  }
}

}  // namespace

std::string StereoMatcher::Options::Validate() const {
  if (min_disparity_px < 0 || max_disparity_px <= min_disparity_px)
    return "need 0 <= min_disparity_px < max_disparity_px";
  if (half_window_px < 1) return "half_window_px must be at least 1";
  if (min_score < -1 || min_score > 1) return "min_score must be in [-1, 1]";
  if (uniqueness_margin < 0) return "uniqueness_margin must not be negative";
  if (left_right_tolerance_px <= 0) return "left_right_tolerance_px must be positive";
  if (refine_iterations < 0) return "refine_iterations must not be negative";
  if (expected_window_px < 1) return "expected_window_px must be at least 1";
  return {};
}

StereoMatcher::StereoMatcher(const Options& options) : options_(options) {
  if (const std::string error = options.Validate(); !error.empty())
    throw Error("invalid stereo matcher options: " + error, "StereoMatcher::Options", "correct the option");
}

StereoMatcher::Peak StereoMatcher::SearchRow(const cv::Mat& from, const cv::Mat& to, const cv::Point2f& p,
                                             int direction, int d_min, int d_max) const {
  const int h = options_.half_window_px;
  const int count = d_max - d_min + 1;
  cv::Mat window, strip, ncc;
  cv::getRectSubPix(from, cv::Size(2 * h + 1, 2 * h + 1), p, window, CV_32F);
  // Column j of the strip's NCC is disparity d_max - j looking left, d_min + j looking right.
  const float centre_x = p.x + direction * 0.5f * static_cast<float>(d_min + d_max);
  cv::getRectSubPix(to, cv::Size(count + 2 * h, 2 * h + 1), cv::Point2f(centre_x, p.y), strip, CV_32F);
  NormalizedCrossCorrelation(strip, window, &ncc);
  const auto disparity_of = [&](int j) { return direction < 0 ? d_max - j : d_min + j; };
  // Windows reaching past the image edge see replicated border pixels, not the scene.
  const auto inside = [&](int j) {
    const float x = p.x + direction * static_cast<float>(disparity_of(j));
    return x - h >= 0 && x + h <= to.cols - 1;
  };
  const float* r = ncc.ptr<float>(0);
  int best = -1;
  for (int j = 0; j < count; ++j)
    if (inside(j) && std::isfinite(r[j]) && (best < 0 || r[j] > r[best])) best = j;
  Peak peak;
  // A maximum at either end of the range is not a peak: the true one may lie beyond.
  if (best <= 0 || best >= count - 1 || r[best] < options_.min_score) return peak;
  // The best elsewhere: beyond the peak's own slopes (as far as they descend).
  int lo = best, hi = best;
  while (lo > 0 && r[lo - 1] < r[lo]) --lo;
  while (hi < count - 1 && r[hi + 1] < r[hi]) ++hi;
  float second = -1;
  for (int j = 0; j < count; ++j)
    if ((j < lo || j > hi) && inside(j)) second = std::max(second, r[j]);
  if (second > r[best] - options_.uniqueness_margin) return peak;
  double offset = 0;
  const double a = r[best - 1], b = r[best], c = r[best + 1];
  const double curvature = a - 2 * b + c;
  if (curvature < 0) offset = 0.5 * (a - c) / curvature;
  peak.found = true;
  peak.score = r[best];
  peak.disparity = disparity_of(best) + (direction < 0 ? -offset : offset);
  return peak;
}

bool StereoMatcher::Refine(const cv::Mat& left, const cv::Mat& right, const cv::Point2f& p, double* disparity) const {
  const int h = options_.half_window_px;
  const cv::Size size(2 * h + 1, 2 * h + 1);
  cv::Mat l = CubicSampler(left, size, p, 0).Sample(p).clone();
  if (!Normalize(&l)) return false;
  const double start = *disparity;
  // The right window and one column either side, for central differences;
  // the disparity stays within a pixel of its start, so one neighbourhood serves every iteration.
  CubicSampler right_sampler(right, cv::Size(size.width + 2, size.height),
                             cv::Point2f(p.x - static_cast<float>(start), p.y), 2);
  for (int it = 0; it < options_.refine_iterations; ++it) {
    const cv::Mat& wide = right_sampler.Sample(cv::Point2f(p.x - static_cast<float>(*disparity), p.y));
    // R is the window's middle columns; plain loops: these windows are too small for cv::Mat arithmetic to pay.
    double sum = 0, sum2 = 0;
    for (int y = 0; y < size.height; ++y) {
      const float* w = wide.ptr<float>(y) + 1;
      for (int x = 0; x < size.width; ++x) sum += w[x], sum2 += double(w[x]) * w[x];
    }
    const double n = static_cast<double>(size.area());
    const double mean = sum / n;
    const double norm = std::sqrt(std::max(0.0, sum2 - n * mean * mean));
    if (norm < 1e-6) return false;
    // Minimise sum (R(x - d - delta) - L)^2 over zero-mean, unit-norm R: R(x - d - delta) ~ R - gx delta,
    // with gx the central difference of R.
    double gg = 0, g_residual = 0;
    for (int y = 0; y < size.height; ++y) {
      const float* w = wide.ptr<float>(y);
      const float* lw = l.ptr<float>(y);
      for (int x = 0; x < size.width; ++x) {
        const double g = 0.5 * (double(w[x + 2]) - w[x]) / norm;
        gg += g * g;
        g_residual += g * ((w[x + 1] - mean) / norm - lw[x]);
      }
    }
    if (gg < 1e-12) return false;
    const double delta = g_residual / gg;
    *disparity += delta;
    if (std::abs(*disparity - start) > 1.0) return false;
    if (std::abs(delta) < 1e-3) break;
  }
  return true;
}

std::vector<StereoMatch> StereoMatcher::Match(const cv::Mat& left, const cv::Mat& right,
                                              const std::vector<cv::Point2f>& uv_left_px,
                                              const std::vector<float>* expected_disparity_px) const {
  DG_CHECK(left.type() == CV_8UC1 && right.type() == CV_8UC1 && left.size() == right.size());
  DG_CHECK(expected_disparity_px == nullptr || expected_disparity_px->size() == uv_left_px.size());
  std::vector<StereoMatch> matches(uv_left_px.size());
  // Points are independent and each writes only its own slot: the result does not depend on the threads.
  tbb::parallel_for(std::size_t{0}, uv_left_px.size(), [&](std::size_t i) {
    const cv::Point2f& p = uv_left_px[i];
    double lo = options_.min_disparity_px, hi = options_.max_disparity_px;
    if (expected_disparity_px != nullptr && (*expected_disparity_px)[i] >= 0) {
      lo = std::max(lo, (*expected_disparity_px)[i] - options_.expected_window_px);
      hi = std::min(hi, (*expected_disparity_px)[i] + options_.expected_window_px);
    }
    const int d_min = static_cast<int>(std::ceil(lo)), d_max = static_cast<int>(std::floor(hi));
    if (d_max - d_min < 2) return;
    const Peak forward = SearchRow(left, right, p, -1, d_min, d_max);
    if (!forward.found) return;
    const cv::Point2f q(p.x - static_cast<float>(forward.disparity), p.y);
    const Peak backward = SearchRow(right, left, q, +1, d_min, d_max);
    if (!backward.found || std::abs(backward.disparity - forward.disparity) > options_.left_right_tolerance_px)
      return;
    double disparity = forward.disparity;
    if (!Refine(left, right, p, &disparity)) return;
    matches[i] = {true, static_cast<float>(disparity), static_cast<float>(forward.score)};
  });
  return matches;
}

}  // namespace dg::stages
