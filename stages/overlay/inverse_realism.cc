#include "stages/overlay/inverse_realism.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include "sim/error.h"

namespace dg::stages::overlay {

std::string InverseRealismOptions::Validate() const {
  if (!(w_edge >= 0 && w_detail >= 0 && w_highlight >= 0)) return "weights must be non-negative";
  if (!(edge_scale > 0 && detail_scale > 0)) return "edge_scale and detail_scale must be positive";
  if (!(highlight_lo < highlight_hi)) return "highlight_lo must be below highlight_hi";
  if (!(strength >= 0 && strength <= 1)) return "strength must be within [0, 1]";
  return {};
}

namespace {

// The filters are OpenCV's 8-bit ones, reproduced in integers so that a band
// of rows is computed in one pass from a few rows of scratch (no full-frame
// intermediates) with the very same values:
//   grey  = (3735 B + 19235 G + 9798 R + 2^14) >> 15 (cvtColor BGR2GRAY: BT.601 in OpenCV's 15-bit
//                                                    weights; checked on all 2^24 colours)
//   smooth = ([1 2 1] x [1 2 1] * grey + 8) >> 4      (GaussianBlur 3x3: the exact kernel 1/4 [1 2 1])
//   blurred = (k x k * smooth + 2^15) >> 16           (GaussianBlur 9x9, sigma 1.7: OpenCV's bit-exact
//              k = [4 13 30 51 60 51 30 13 4] / 256, each pass exact in integers, rounded once)
//   gx, gy = Sobel 3x3 of smooth                     (exact)
// all with OpenCV's default border, reflect-101 (... 2 1 | 0 1 2 ...).
constexpr int kGreyB = 3735, kGreyG = 19235, kGreyR = 9798, kGreyShift = 15;
constexpr int kBlurRadius = 4;
constexpr std::uint16_t kBlur[kBlurRadius + 1] = {60, 51, 30, 13, 4};  // centre, then at +-1 ... +-4
constexpr int kGreyHalo = kBlurRadius + 1;  // grey rows a band needs beyond it: the blur's and the smoothing's
// Below this size reflect-101 would reflect more than once; such frames take OpenCV's filters.
constexpr int kMinFusedSize = 2 * kBlurRadius + 1;

int Reflect101(int i, int n) { return i < 0 ? -i : i >= n ? 2 * n - 2 - i : i; }

struct Gains {
  float edge, detail, highlight_lo, highlight_ramp, w_highlight;
};

Gains GainsOf(const InverseRealismOptions& options) {
  // Sobel's 3x3 kernel weighs the gradient by 8; 8-bit levels to [0, 1].
  return {options.w_edge / (8 * 255.0f * options.edge_scale), options.w_detail / (255.0f * options.detail_scale),
          options.highlight_lo, 1 / (options.highlight_hi - options.highlight_lo), options.w_highlight};
}

// sqrt(float(in[x])): vectorised by hand, as the compiler keeps std::sqrt scalar for errno's sake.
void SqrtRow(const std::int32_t* in, int n, float* out) {
  int x = 0;
#if defined(__AVX512F__)
  for (; x + 16 <= n; x += 16)
    _mm512_storeu_ps(out + x, _mm512_sqrt_ps(_mm512_cvtepi32_ps(_mm512_loadu_si512(in + x))));
#elif defined(__AVX2__)
  for (; x + 8 <= n; x += 8)
    _mm256_storeu_ps(out + x, _mm256_sqrt_ps(_mm256_cvtepi32_ps(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(in + x)))));
#endif
  for (; x < n; ++x) out[x] = std::sqrt(float(in[x]));
}

// One row's cues. gradient2: the squared Sobel magnitude; detail: |smooth - blurred|.
struct RowCues {
  std::vector<std::int32_t> gradient2, detail;
  std::vector<std::uint8_t> value, low;  // max and min of B, G, R
  std::vector<float> gradient;           // sqrt(gradient2)
  void Resize(int cols) {
    gradient2.resize(cols);
    detail.resize(cols);
    value.resize(cols);
    low.resize(cols);
    gradient.resize(cols);
  }
};

// s = min(1, e + t + h) of one row (the header's formula).
void SaliencyRow(const std::uint8_t* bgr, int cols, const Gains& g, RowCues* cues, float* out) {
  std::uint8_t *value_255 = cues->value.data(), *low_255 = cues->low.data();
  for (int x = 0; x < cols; ++x) {
    const std::uint8_t b = bgr[3 * x], gr = bgr[3 * x + 1], r = bgr[3 * x + 2];
    value_255[x] = std::max(std::max(b, gr), r);
    low_255[x] = std::min(std::min(b, gr), r);
  }
  SqrtRow(cues->gradient2.data(), cols, cues->gradient.data());
  const float* gradient = cues->gradient.data();
  const std::int32_t* detail = cues->detail.data();
  for (int x = 0; x < cols; ++x) {
    const float edge = g.edge * gradient[x];
    const float texture = g.detail * float(detail[x]);
    const float value = value_255[x] * (1 / 255.0f);
    const float low = low_255[x] * (1 / 255.0f);
    // value > 0 ? (value - low) / value : 0, without the branch: value is 0 or at least 1/255.
    const float saturation = (value - low) / std::max(value, 1e-30f);
    const float ramp = std::clamp((value - g.highlight_lo) * g.highlight_ramp, 0.0f, 1.0f);
    const float highlight = g.w_highlight * ramp * (1 - saturation);
    out[x] = std::min(1.0f, edge + texture + highlight);
  }
}

// OpenCV's own filters over the whole frame: for frames too small for the fused pass.
cv::Mat SaliencyByOpenCv(const cv::Mat& frame_bgr, const InverseRealismOptions& options) {
  cv::Mat grey, smooth, blurred, gx, gy;
  cv::cvtColor(frame_bgr, grey, cv::COLOR_BGR2GRAY);
  cv::GaussianBlur(grey, smooth, cv::Size(3, 3), 0);          // sensor noise is not an edge
  cv::GaussianBlur(smooth, blurred, cv::Size(9, 9), 0);       // below this scale: fine texture
  cv::Sobel(smooth, gx, CV_16S, 1, 0, 3);
  cv::Sobel(smooth, gy, CV_16S, 0, 1, 3);
  cv::Mat saliency(frame_bgr.size(), CV_32F);
  const Gains gains = GainsOf(options);
  RowCues cues;
  cues.Resize(frame_bgr.cols);
  for (int y = 0; y < frame_bgr.rows; ++y) {
    for (int x = 0; x < frame_bgr.cols; ++x) {
      const int dx = gx.at<std::int16_t>(y, x), dy = gy.at<std::int16_t>(y, x);
      cues.gradient2[x] = dx * dx + dy * dy;
      cues.detail[x] = std::abs(int(smooth.at<std::uint8_t>(y, x)) - int(blurred.at<std::uint8_t>(y, x)));
    }
    SaliencyRow(frame_bgr.ptr<std::uint8_t>(y), frame_bgr.cols, gains, &cues, saliency.ptr<float>(y));
  }
  return saliency;
}

// Per-thread rows of one band, kept between bands and frames.
struct BandScratch {
  std::vector<std::uint8_t> grey;     // grey rows of the band and its halo, 1 reflected pixel either side
  std::vector<std::uint8_t> smooth;   // smoothed rows, kBlurRadius reflected pixels either side
  std::vector<std::uint16_t> across;  // smoothed rows filtered along the row by the 9-tap kernel
  std::vector<std::uint16_t> column;  // one row of [1 2 1] down the grey columns
  RowCues cues;
};

void FusedBand(const cv::Mat& frame_bgr, const Gains& gains, int y_begin, int y_end, cv::Mat* band) {
  thread_local BandScratch scratch;
  const int rows = frame_bgr.rows, cols = frame_bgr.cols;
  const int grey_begin = std::max(0, y_begin - kGreyHalo), grey_end = std::min(rows, y_end + kGreyHalo);
  const int smooth_begin = std::max(0, y_begin - kBlurRadius), smooth_end = std::min(rows, y_end + kBlurRadius);
  const int grey_step = cols + 2, smooth_step = cols + 2 * kBlurRadius;
  scratch.grey.resize(static_cast<size_t>(grey_end - grey_begin) * grey_step);
  scratch.smooth.resize(static_cast<size_t>(smooth_end - smooth_begin) * smooth_step);
  scratch.across.resize(static_cast<size_t>(smooth_end - smooth_begin) * cols);
  scratch.column.resize(cols + 2);
  scratch.cues.Resize(cols);

  // Row r's first pixel; reflected rows are the band's own (a band is at least as tall as the frame needs).
  const auto grey_row = [&](int r) { return scratch.grey.data() + (Reflect101(r, rows) - grey_begin) * grey_step + 1; };
  const auto smooth_row = [&](int r) {
    return scratch.smooth.data() + (Reflect101(r, rows) - smooth_begin) * smooth_step + kBlurRadius;
  };
  const auto across_row = [&](int r) { return scratch.across.data() + (Reflect101(r, rows) - smooth_begin) * cols; };

  for (int r = grey_begin; r < grey_end; ++r) {
    const std::uint8_t* bgr = frame_bgr.ptr<std::uint8_t>(r);
    std::uint8_t* grey = grey_row(r);
    for (int x = 0; x < cols; ++x) {
      grey[x] = static_cast<std::uint8_t>(
          (kGreyB * bgr[3 * x] + kGreyG * bgr[3 * x + 1] + kGreyR * bgr[3 * x + 2] + (1 << (kGreyShift - 1))) >>
          kGreyShift);
    }
    grey[-1] = grey[1];
    grey[cols] = grey[cols - 2];
  }
  std::uint16_t* column = scratch.column.data() + 1;
  for (int r = smooth_begin; r < smooth_end; ++r) {
    const std::uint8_t *above = grey_row(r - 1), *centre = grey_row(r), *below = grey_row(r + 1);
    for (int x = -1; x <= cols; ++x) column[x] = std::uint16_t(above[x] + 2 * centre[x] + below[x]);
    std::uint8_t* smooth = smooth_row(r);
    for (int x = 0; x < cols; ++x) smooth[x] = std::uint8_t((column[x - 1] + 2 * column[x] + column[x + 1] + 8) >> 4);
    for (int k = 1; k <= kBlurRadius; ++k) {
      smooth[-k] = smooth[k];
      smooth[cols - 1 + k] = smooth[cols - 1 - k];
    }
    std::uint16_t* across = across_row(r);
    for (int x = 0; x < cols; ++x) {
      across[x] = std::uint16_t(kBlur[0] * smooth[x] + kBlur[1] * (smooth[x - 1] + smooth[x + 1]) +
                                kBlur[2] * (smooth[x - 2] + smooth[x + 2]) + kBlur[3] * (smooth[x - 3] + smooth[x + 3]) +
                                kBlur[4] * (smooth[x - 4] + smooth[x + 4]));
    }
  }
  std::int32_t *gradient2 = scratch.cues.gradient2.data(), *detail = scratch.cues.detail.data();
  for (int y = y_begin; y < y_end; ++y) {
    const std::uint16_t *a0 = across_row(y), *a1 = across_row(y - 1), *b1 = across_row(y + 1), *a2 = across_row(y - 2),
                        *b2 = across_row(y + 2), *a3 = across_row(y - 3), *b3 = across_row(y + 3),
                        *a4 = across_row(y - 4), *b4 = across_row(y + 4);
    const std::uint8_t *above = smooth_row(y - 1), *centre = smooth_row(y), *below = smooth_row(y + 1);
    for (int x = 0; x < cols; ++x) {
      const std::uint32_t sum = std::uint32_t(kBlur[0]) * a0[x] + std::uint32_t(kBlur[1]) * (a1[x] + b1[x]) +
                                std::uint32_t(kBlur[2]) * (a2[x] + b2[x]) + std::uint32_t(kBlur[3]) * (a3[x] + b3[x]) +
                                std::uint32_t(kBlur[4]) * (a4[x] + b4[x]);
      const std::int32_t blurred = std::int32_t((sum + (1u << 15)) >> 16);
      const std::int32_t dx = (above[x + 1] - above[x - 1]) + 2 * (centre[x + 1] - centre[x - 1]) + (below[x + 1] - below[x - 1]);
      const std::int32_t dy = (below[x - 1] + 2 * below[x] + below[x + 1]) - (above[x - 1] + 2 * above[x] + above[x + 1]);
      gradient2[x] = dx * dx + dy * dy;
      detail[x] = std::abs(centre[x] - blurred);
    }
    SaliencyRow(frame_bgr.ptr<std::uint8_t>(y), cols, gains, &scratch.cues, band->ptr<float>(y - y_begin));
  }
}

void CheckFrame(const cv::Mat& frame_bgr) {
  if (frame_bgr.type() != CV_8UC3)
    throw Error("the video frame is not 8-bit BGR", "inverse realism", "pass the captured colour frame");
}

}  // namespace

void SaliencyBand(const cv::Mat& frame_bgr, const InverseRealismOptions& options, int y_begin, int y_end,
                  cv::Mat* band) {
  CheckFrame(frame_bgr);
  DG_CHECK(0 <= y_begin && y_begin < y_end && y_end <= frame_bgr.rows);
  band->create(y_end - y_begin, frame_bgr.cols, CV_32F);
  if (frame_bgr.rows < kMinFusedSize || frame_bgr.cols < kMinFusedSize) {
    SaliencyByOpenCv(frame_bgr, options).rowRange(y_begin, y_end).copyTo(*band);
    return;
  }
  FusedBand(frame_bgr, GainsOf(options), y_begin, y_end, band);
}

cv::Mat Saliency(const cv::Mat& frame_bgr, const InverseRealismOptions& options) {
  CheckFrame(frame_bgr);
  if (frame_bgr.rows < kMinFusedSize || frame_bgr.cols < kMinFusedSize) return SaliencyByOpenCv(frame_bgr, options);
  cv::Mat saliency(frame_bgr.size(), CV_32F);
  const Gains gains = GainsOf(options);
  constexpr int kBandRows = 32;  // the halo (2 x 5 rows) is recomputed per band
  const int bands = (frame_bgr.rows + kBandRows - 1) / kBandRows;
  tbb::parallel_for(0, bands, [&](int i) {
    const int y_begin = i * kBandRows, y_end = std::min(frame_bgr.rows, y_begin + kBandRows);
    cv::Mat rows = saliency.rowRange(y_begin, y_end);
    FusedBand(frame_bgr, gains, y_begin, y_end, &rows);
  });
  return saliency;
}

}  // namespace dg::stages::overlay
