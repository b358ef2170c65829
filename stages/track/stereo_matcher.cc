#include "stages/track/stereo_matcher.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <vector>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "sim/error.h"

namespace dg::stages {
namespace {

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

// The cross term of the search's NCC is summed over kLanes offsets at once,
// one 512-bit vector (two 256-bit ones without AVX-512): a tracked point's
// range of 9 offsets is one block. The strip buffer has kLanes spare floats
// so that the last block may read past its end.
constexpr int kLanes = 16;
// GCC's vector extension: an array of lanes would be kept in memory, one store per addition.
typedef float Lanes __attribute__((vector_size(kLanes * sizeof(float))));

// The samplers write kBlock columns at a time (one 256-bit vector); a row's
// last block spills into the next row, which then overwrites it, and past
// the last row into kPad spare floats at the end of each buffer. Their fast
// paths read as far past the window as they write.
constexpr int kBlock = 8, kPad = 2 * kBlock;
typedef float Floats __attribute__((vector_size(kBlock * sizeof(float))));

// GCC 12 converts a vector of bytes to floats one lane at a time; AVX2 has the instruction.
// (Vectors are passed by pointer: by value they would change the ABI without AVX.)
void Load(const uchar* p, Floats* v) {
#if defined(__AVX2__)
  *v = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p))));
#else
  for (int k = 0; k < kBlock; ++k) (*v)[k] = p[k];
#endif
}
void Load(const float* p, Floats* v) { std::memcpy(v, p, sizeof *v); }

// One output block of a four-tap filter: out[k] = w0 a[k] + w1 b[k] + w2 c[k] + w3 d[k], k < kBlock.
template <typename T>
void FourTaps(const T* a, const T* b, const T* c, const T* d, const std::array<float, 4>& w, float* out) {
  Floats va, vb, vc, vd;
  Load(a, &va), Load(b, &vb), Load(c, &vc), Load(d, &vd);
  const Floats sum = w[0] * va + w[1] * vb + w[2] * vc + w[3] * vd;
  std::memcpy(out, &sum, sizeof sum);
}

// One task's buffers: they grow to the largest window and range met and are
// then reused, so that matching a point allocates nothing.
struct Buffers {
  std::vector<float> window, strip, centred, cross, ncc;  // row search
  std::vector<double> column_sum, column_sum2;       // row search
  std::vector<float> rows, left, wide;               // refinement
};

// The w x h window centred at (cx, cy), bilinear into float as
// cv::getRectSubPix: pixels beyond the image repeat its edge.
void SampleBilinear(const cv::Mat& image, float cx, float cy, int w, int h, float* out) {
  const float ox = cx - 0.5f * static_cast<float>(w - 1), oy = cy - 0.5f * static_cast<float>(h - 1);
  const int x0 = static_cast<int>(std::floor(ox)), y0 = static_cast<int>(std::floor(oy));
  const float a = ox - static_cast<float>(x0), b = oy - static_cast<float>(y0);
  const float w00 = (1 - a) * (1 - b), w01 = a * (1 - b), w10 = (1 - a) * b, w11 = a * b;
  const std::array<float, 4> weights = {w00, w01, w10, w11};
  if (x0 >= 0 && y0 >= 0 && x0 + w + kBlock < image.cols && y0 + h < image.rows) {
    for (int r = 0; r < h; ++r, out += w) {
      const uchar* s0 = image.ptr<uchar>(y0 + r) + x0;
      const uchar* s1 = image.ptr<uchar>(y0 + r + 1) + x0;
      for (int c = 0; c < w; c += kBlock)
        FourTaps(s0 + c, s0 + c + 1, s1 + c, s1 + c + 1, weights, out + c);
    }
    return;
  }
  const auto at = [&](int y, int x) {
    return static_cast<float>(image.at<uchar>(std::clamp(y, 0, image.rows - 1), std::clamp(x, 0, image.cols - 1)));
  };
  for (int r = 0; r < h; ++r, out += w) {
    const int y = y0 + r;
    for (int c = 0; c < w; ++c) {
      const int x = x0 + c;
      out[c] = w00 * at(y, x) + w01 * at(y, x + 1) + w10 * at(y + 1, x) + w11 * at(y + 1, x + 1);
    }
  }
}

// cv::matchTemplate's TM_CCOEFF_NORMED of the w x h `window` at each of
// `count` offsets along `strip` ((count + w - 1) x h, row-major), into ncc:
//   ncc(j) = sum (t - mean t) s / sqrt(sum (t - mean t)^2 * (sum s^2 - (sum s)^2 / n))
// over the window at offset j. The window is centred once, so the cross term
// needs no strip mean; the strip's sums come from its column sums, each
// column summed once rather than once per offset. A flat strip window scores 0.
void NormalizedCrossCorrelation(const float* strip, const float* window, int w, int h, int count, Buffers* b,
                                float* ncc) {
  const int cols = count + w - 1, area = w * h;
  const double n = static_cast<double>(area);
  // Sums in double, two partial sums each: one chain of dependent additions would wait on every add.
  double sum_even = 0, sum_odd = 0, sum2_even = 0, sum2_odd = 0;
  int k = 0;
  for (; k + 1 < area; k += 2) {
    sum_even += window[k], sum2_even += static_cast<double>(window[k]) * window[k];
    sum_odd += window[k + 1], sum2_odd += static_cast<double>(window[k + 1]) * window[k + 1];
  }
  if (k < area) sum_even += window[k], sum2_even += static_cast<double>(window[k]) * window[k];
  const double window_mean = (sum_even + sum_odd) / n;
  const double window_norm2 = std::max(0.0, sum2_even + sum2_odd - n * window_mean * window_mean);
  b->centred.resize(area);
  float* centred = b->centred.data();
  for (int k = 0; k < area; ++k) centred[k] = static_cast<float>(window[k] - window_mean);
  b->column_sum.assign(cols, 0.0);
  b->column_sum2.assign(cols, 0.0);
  for (int y = 0; y < h; ++y) {
    const float* s = strip + y * cols;
    for (int c = 0; c < cols; ++c) {
      b->column_sum[c] += s[c];
      b->column_sum2[c] += static_cast<double>(s[c]) * s[c];
    }
  }
  // The cross term, kLanes offsets at a time; even and odd rows in two sums, as above.
  const int blocks = (count + kLanes - 1) / kLanes;
  b->cross.resize(static_cast<size_t>(blocks) * kLanes);
  for (int block = 0; block < blocks; ++block) {
    Lanes even = {}, odd = {};
    const auto add_row = [&](int y, Lanes* acc) {
      const float* t = centred + y * w;
      const float* s = strip + y * cols + block * kLanes;
      for (int x = 0; x < w; ++x) {
        Lanes strip_lanes;
        std::memcpy(&strip_lanes, s + x, sizeof strip_lanes);
        *acc += t[x] * strip_lanes;
      }
    };
    int y = 0;
    for (; y + 1 < h; y += 2) add_row(y, &even), add_row(y + 1, &odd);
    if (y < h) add_row(y, &even);
    const Lanes cross = even + odd;
    std::memcpy(b->cross.data() + block * kLanes, &cross, sizeof cross);
  }
  double sum = 0, sum2 = 0;
  for (int c = 0; c < w - 1; ++c) sum += b->column_sum[c], sum2 += b->column_sum2[c];
  for (int j = 0; j < count; ++j) {
    sum += b->column_sum[j + w - 1];
    sum2 += b->column_sum2[j + w - 1];
    const double strip_norm2 = std::max(0.0, sum2 - sum * sum / n);
    const double denominator = std::sqrt(strip_norm2 * window_norm2);
    ncc[j] = denominator > 1e-6 ? static_cast<float>(b->cross[j] / denominator) : 0.0f;
    sum -= b->column_sum[j];
    sum2 -= b->column_sum2[j];
  }
}

// Bicubic windows (the weights above) whose rows all lie at one sub-pixel
// height, as every window of the refinement does: bilinear sampling
// (getRectSubPix) smooths differently at each fraction of a pixel and biases
// the sub-pixel estimate by a few hundredths of a pixel, and an 8-bit result
// would be rounded to whole grey levels. The kernel is separable, so the image
// rows are filtered along y once, into `rows` (h rows of the columns
// [x_lo, x_lo + width)), and each window is then a 4-tap filter of those
// along x (SampleAlongX), with exact weights (cv::remap rounds them to 1/32 px).
// Pixels beyond the image repeat its edge.
void FilterAlongY(const cv::Mat& image, float origin_y, int h, int x_lo, int width, std::vector<float>* rows) {
  const int y0 = static_cast<int>(std::floor(origin_y));
  const std::array<float, 4> wy = CubicWeights(origin_y - static_cast<float>(y0));
  rows->resize(static_cast<size_t>(h) * width + kPad);
  const bool inside = x_lo >= 0 && x_lo + width + kBlock <= image.cols;
  for (int r = 0; r < h; ++r) {
    const uchar* in[4];
    for (int j = 0; j < 4; ++j) in[j] = image.ptr<uchar>(std::clamp(y0 + r + j - 1, 0, image.rows - 1));
    float* out = rows->data() + static_cast<size_t>(r) * width;
    if (inside) {
      for (int c = 0; c < width; c += kBlock) {
        const int x = x_lo + c;
        FourTaps(in[0] + x, in[1] + x, in[2] + x, in[3] + x, wy, out + c);
      }
    } else {
      for (int c = 0; c < width; ++c) {
        const int x = std::clamp(x_lo + c, 0, image.cols - 1);
        out[c] = wy[0] * in[0][x] + wy[1] * in[1][x] + wy[2] * in[2][x] + wy[3] * in[3][x];
      }
    }
  }
}

// The w x h window whose top-left pixel lies at origin_x along the rows
// FilterAlongY made from column x_lo on, `width` wide.
void SampleAlongX(const std::vector<float>& rows, int x_lo, int width, float origin_x, int w, int h, float* out) {
  const int x0 = static_cast<int>(std::floor(origin_x));
  const std::array<float, 4> wx = CubicWeights(origin_x - static_cast<float>(x0));
  const int first = x0 - 1 - x_lo;  // the first tap of the window's first column
  DG_CHECK(first >= 0 && first + w + 3 <= width && rows.size() >= static_cast<size_t>(h) * width + kPad);
  for (int r = 0; r < h; ++r, out += w) {
    const float* in = rows.data() + static_cast<size_t>(r) * width + first;
    for (int c = 0; c < w; c += kBlock)
      FourTaps(in + c, in + c + 1, in + c + 2, in + c + 3, wx, out + c);
  }
}

}  // namespace

struct StereoMatcher::Scratch : Buffers {};
struct StereoMatcher::ScratchPerThread : tbb::enumerable_thread_specific<Scratch> {};

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

StereoMatcher::StereoMatcher(const Options& options)
    : options_(options), scratch_(std::make_shared<ScratchPerThread>()) {
  if (const std::string error = options.Validate(); !error.empty())
    throw Error("invalid stereo matcher options: " + error, "StereoMatcher::Options", "correct the option");
}

StereoMatcher::Peak StereoMatcher::SearchRow(const cv::Mat& from, const cv::Mat& to, const cv::Point2f& p,
                                             int direction, int d_min, int d_max, Scratch* scratch) const {
  const int h = options_.half_window_px, w = 2 * h + 1;
  const int count = d_max - d_min + 1, cols = count + 2 * h;
  scratch->window.resize(static_cast<size_t>(w) * w + kPad);
  SampleBilinear(from, p.x, p.y, w, w, scratch->window.data());
  // Column j of the strip's NCC is disparity d_max - j looking left, d_min + j looking right.
  const float centre_x = p.x + direction * 0.5f * static_cast<float>(d_min + d_max);
  scratch->strip.assign(static_cast<size_t>(cols) * w + std::max(kLanes, kPad), 0.0f);
  SampleBilinear(to, centre_x, p.y, cols, w, scratch->strip.data());
  std::vector<float>& ncc = scratch->ncc;
  ncc.resize(count);
  NormalizedCrossCorrelation(scratch->strip.data(), scratch->window.data(), w, w, count, scratch, ncc.data());
  const auto disparity_of = [&](int j) { return direction < 0 ? d_max - j : d_min + j; };
  // Windows reaching past the image edge see replicated border pixels, not the scene.
  const auto inside = [&](int j) {
    const float x = p.x + direction * static_cast<float>(disparity_of(j));
    return x - h >= 0 && x + h <= to.cols - 1;
  };
  const float* r = ncc.data();
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

bool StereoMatcher::Refine(const cv::Mat& left, const cv::Mat& right, const cv::Point2f& p, double* disparity,
                          Scratch* scratch) const {
  const int h = options_.half_window_px, w = 2 * h + 1, area = w * w;
  const float top = p.y - static_cast<float>(h);  // every window's first row, left and right
  // L: the left window, zero mean and unit norm.
  const float left_origin = p.x - static_cast<float>(h);
  const int left_lo = static_cast<int>(std::floor(left_origin)) - 2;
  FilterAlongY(left, top, w, left_lo, w + 5, &scratch->rows);
  std::vector<float>& l = scratch->left;
  l.resize(area + kPad);
  SampleAlongX(scratch->rows, left_lo, w + 5, left_origin, w, w, l.data());
  double left_sum = 0;
  for (int k = 0; k < area; ++k) left_sum += l[k];
  const double left_mean = left_sum / area;
  double left_norm2 = 0;
  for (int k = 0; k < area; ++k) left_norm2 += (l[k] - left_mean) * (l[k] - left_mean);
  if (std::sqrt(left_norm2) < 1e-6) return false;
  const double left_norm = std::sqrt(left_norm2);
  for (int k = 0; k < area; ++k) l[k] = static_cast<float>((l[k] - left_mean) / left_norm);
  // The right window and one column either side, for central differences. The
  // disparity stays within a pixel of its start, so the window's left edge
  // stays in [centre - h - 2, centre - h] and its taps in the columns filtered here.
  const double start = *disparity;
  const int wide_w = w + 2;
  const int right_lo = static_cast<int>(std::floor(p.x - static_cast<float>(start))) - h - 4;
  const int right_width = wide_w + 8;
  FilterAlongY(right, top, w, right_lo, right_width, &scratch->rows);
  std::vector<float>& wide = scratch->wide;
  wide.resize(static_cast<size_t>(wide_w) * w + kPad);
  for (int it = 0; it < options_.refine_iterations; ++it) {
    const float centre = p.x - static_cast<float>(*disparity);
    SampleAlongX(scratch->rows, right_lo, right_width, centre - static_cast<float>(h + 1), wide_w, w, wide.data());
    // R is the window's middle columns (c), gx their central difference (d / 2). One pass of six
    // independent sums, no division per pixel: these windows are too small for cv::Mat arithmetic to pay.
    double sum = 0, sum2 = 0, dd = 0, dc = 0, d_sum = 0, dl = 0;
    for (int y = 0; y < w; ++y) {
      const float* r = wide.data() + y * wide_w;
      const float* lw = l.data() + y * w;
      for (int x = 0; x < w; ++x) {
        const double c = r[x + 1], d = double(r[x + 2]) - r[x];
        sum += c, sum2 += c * c;
        dd += d * d, dc += d * c, d_sum += d, dl += d * lw[x];
      }
    }
    const double n = static_cast<double>(area);
    const double mean = sum / n;
    const double norm = std::sqrt(std::max(0.0, sum2 - n * mean * mean));
    if (norm < 1e-6) return false;
    // Minimise sum (R(x - d - delta) - L)^2 over zero-mean, unit-norm R: R(x - d - delta) ~ R - gx delta,
    // gx = d / (2 norm) and R = (c - mean) / norm, so
    //   sum gx^2 = dd / (4 norm^2),  sum gx (R - L) = (dc - mean d_sum) / (2 norm^2) - dl / (2 norm).
    const double gg = dd / (4 * norm * norm);
    const double g_residual = (dc - mean * d_sum) / (2 * norm * norm) - dl / (2 * norm);
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
  const auto match_one = [&](std::size_t i, Scratch* scratch) {
    const cv::Point2f& p = uv_left_px[i];
    double lo = options_.min_disparity_px, hi = options_.max_disparity_px;
    if (expected_disparity_px != nullptr && (*expected_disparity_px)[i] >= 0) {
      lo = std::max(lo, (*expected_disparity_px)[i] - options_.expected_window_px);
      hi = std::min(hi, (*expected_disparity_px)[i] + options_.expected_window_px);
    }
    const int d_min = static_cast<int>(std::ceil(lo)), d_max = static_cast<int>(std::floor(hi));
    if (d_max - d_min < 2) return;
    const Peak forward = SearchRow(left, right, p, -1, d_min, d_max, scratch);
    if (!forward.found) return;
    const cv::Point2f q(p.x - static_cast<float>(forward.disparity), p.y);
    const Peak backward = SearchRow(right, left, q, +1, d_min, d_max, scratch);
    if (!backward.found || std::abs(backward.disparity - forward.disparity) > options_.left_right_tolerance_px)
      return;
    double disparity = forward.disparity;
    if (!Refine(left, right, p, &disparity, scratch)) return;
    matches[i] = {true, static_cast<float>(disparity), static_cast<float>(forward.score)};
  };
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, uv_left_px.size()),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      Scratch& scratch = scratch_->local();
                      for (std::size_t i = range.begin(); i != range.end(); ++i) match_one(i, &scratch);
                    });
  return matches;
}

}  // namespace dg::stages
