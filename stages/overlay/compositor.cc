#include "stages/overlay/compositor.h"

#include <algorithm>
#include <array>

#if defined(__AVX512F__) && defined(__AVX512BW__) && defined(__AVX512VL__)
#include <immintrin.h>
#define DG_COMPOSE_AVX512 1
#endif

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "sim/error.h"

namespace dg::stages::overlay {
namespace {

// Rows per task: the saliency recomputes 5 rows of halo either side of a band
// (inverse_realism.cc), and 15 bands at 480 rows balance 2 threads.
constexpr int kBandRows = 32;

// The layers over one row of video, each pixel once through all of them:
// c = video / 255; per layer in order, with keep = 1 - strength s where the
// layer is blended by Inverse Realism (s the frame's saliency) and 1 otherwise,
//   c = keep p_bgr + (1 - keep p_a) c      (premultiplied "over", its opacity times keep);
// out = saturate(round(255 c)).
struct RowJob {
  const std::uint8_t* video_bgr;
  std::uint8_t* out_bgr;
  int cols;
  const float* const* layers_bgra;  // one row per layer
  const std::uint8_t* salient;      // per layer: 1 if blended by Inverse Realism
  int num_layers;
  const float* saliency;  // the row's, if any layer is salient
  float strength;
};

#if defined(DG_COMPOSE_AVX512)
// Four pixels per vector, as they lie in the layers (B G R A each); the video
// and the result are spread to and packed from that layout. The masks cover
// the pixels of a row's last, partial group.
void ComposeRow(const RowJob& job) {
  const __m128i spread = _mm_setr_epi8(0, 1, 2, -1, 3, 4, 5, -1, 6, 7, 8, -1, 9, 10, 11, -1);
  const __m128i pack = _mm_setr_epi8(0, 1, 2, 4, 5, 6, 8, 9, 10, 12, 13, 14, -1, -1, -1, -1);
  const __m512i quad = _mm512_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3);
  const __m512 one = _mm512_set1_ps(1.0f), to_unit = _mm512_set1_ps(1 / 255.0f), to_byte = _mm512_set1_ps(255.0f);
  const __m128 strength = _mm_set1_ps(job.strength);
  for (int x = 0; x < job.cols; x += 4) {
    const int n = std::min(4, job.cols - x);
    const __mmask16 floats = static_cast<__mmask16>((1u << (4 * n)) - 1), bytes = static_cast<__mmask16>((1u << (3 * n)) - 1);
    const __m128i video = _mm_shuffle_epi8(_mm_maskz_loadu_epi8(bytes, job.video_bgr + 3 * x), spread);
    __m512 c = _mm512_mul_ps(_mm512_cvtepi32_ps(_mm512_cvtepu8_epi32(video)), to_unit);
    __m512 keep = one;
    if (job.saliency) {
      const __m128 s = _mm_maskz_loadu_ps(static_cast<__mmask8>((1u << n) - 1), job.saliency + x);
      keep = _mm512_permutexvar_ps(quad, _mm512_castps128_ps512(_mm_fnmadd_ps(strength, s, _mm_set1_ps(1.0f))));
    }
    for (int l = 0; l < job.num_layers; ++l) {
      const __m512 p = _mm512_maskz_loadu_ps(floats, job.layers_bgra[l] + 4 * x);
      const __m512 alpha = _mm512_permute_ps(p, 0xFF);
      if (job.salient[l]) {
        c = _mm512_fmadd_ps(keep, p, _mm512_mul_ps(_mm512_fnmadd_ps(keep, alpha, one), c));
      } else {
        c = _mm512_fmadd_ps(_mm512_sub_ps(one, alpha), c, p);
      }
    }
    const __m512i rounded = _mm512_max_epi32(_mm512_cvtps_epi32(_mm512_mul_ps(c, to_byte)), _mm512_setzero_si512());
    _mm_mask_storeu_epi8(job.out_bgr + 3 * x, bytes, _mm_shuffle_epi8(_mm512_cvtusepi32_epi8(rounded), pack));
  }
}
#else
void ComposeRow(const RowJob& job) {
  for (int x = 0; x < job.cols; ++x) {
    const std::uint8_t* in = job.video_bgr + 3 * x;
    float c[3] = {in[0] * (1 / 255.0f), in[1] * (1 / 255.0f), in[2] * (1 / 255.0f)};
    for (int l = 0; l < job.num_layers; ++l) {
      const float* p = job.layers_bgra[l] + 4 * x;
      const float keep = job.salient[l] ? 1 - job.strength * job.saliency[x] : 1.0f;
      const float under = 1 - keep * p[3];
      for (int k = 0; k < 3; ++k) c[k] = keep * p[k] + under * c[k];
    }
    for (int k = 0; k < 3; ++k) job.out_bgr[3 * x + k] = cv::saturate_cast<std::uint8_t>(255 * c[k]);
  }
}
#endif

}  // namespace

std::string CompositorOptions::Validate() const {
  if (layers.size() > kMaxLayers) return "more than " + std::to_string(kMaxLayers) + " overlays";
  for (size_t i = 0; i < layers.size(); ++i) {
    if (layers[i].name.empty()) return "layer " + std::to_string(i) + " has no name";
    for (size_t j = 0; j < i; ++j) {
      if (layers[j].name == layers[i].name) return "overlay '" + layers[i].name + "' is listed twice";
    }
  }
  return inverse_realism.Validate();
}

Compositor::Compositor(CompositorOptions options) : options_(std::move(options)), held_(options_.layers.size()) {
  if (const std::string problem = options_.Validate(); !problem.empty())
    throw Error("invalid compositor options: " + problem, "overlay order", "correct the scene's overlay order and blending");
}

void Compositor::Offer(int overlay, OverlayLayer layer) {
  if (overlay < 0 || overlay >= static_cast<int>(held_.size()))
    throw Error("no overlay " + std::to_string(overlay), "Compositor::Offer",
                "offer layers only of the overlays the compositor was configured with");
  if (held_[overlay].empty() || layer.frame > held_[overlay].frame) held_[overlay] = std::move(layer);
}

int Compositor::held_layers() const {
  int held = 0;
  for (const OverlayLayer& layer : held_) held += !layer.empty();
  return held;
}

CompositeFrame Compositor::Compose(const cv::Mat& video_bgr, std::int64_t frame,
                                   std::span<const OverlayLayer> layers) const {
  CompositeFrame out;
  out.frame = frame;
  Compose(video_bgr, frame, layers, &out.bgr, &out.layer_age_frames);
  return out;
}

CompositeFrame Compositor::Compose(const cv::Mat& video_bgr, std::int64_t frame) const {
  return Compose(video_bgr, frame, held_);
}

void Compositor::Compose(const cv::Mat& video_bgr, std::int64_t frame, cv::Mat* composite_bgr,
                         std::vector<std::int64_t>* layer_age_frames) const {
  Compose(video_bgr, frame, held_, composite_bgr, layer_age_frames);
}

void Compositor::Compose(const cv::Mat& video_bgr, std::int64_t frame, std::span<const OverlayLayer> layers,
                         cv::Mat* composite_bgr, std::vector<std::int64_t>* layer_age_frames) const {
  const auto where = [frame] { return "compositor, frame " + std::to_string(frame); };
  if (video_bgr.type() != CV_8UC3) throw Error("the video frame is not 8-bit BGR", where(), "pass the captured colour frame");
  if (layers.size() != options_.layers.size())
    throw Error(std::to_string(layers.size()) + " layers for " + std::to_string(options_.layers.size()) + " overlays",
                where(), "pass one layer per overlay of the options, an empty one where an overlay has none yet");
  composite_bgr->create(video_bgr.size(), CV_8UC3);  // no-op when it has that size and type already
  if (layer_age_frames) layer_age_frames->clear();
  std::array<const OverlayLayer*, CompositorOptions::kMaxLayers> used_layers;
  std::array<std::uint8_t, CompositorOptions::kMaxLayers> salient;  // per used layer
  size_t used = 0;
  for (size_t i = 0; i < options_.layers.size(); ++i) {
    const OverlayLayer& layer = layers[i];
    const bool usable = !layer.empty() && layer.frame <= frame;
    if (layer_age_frames) layer_age_frames->push_back(usable ? frame - layer.frame : -1);
    if (!usable) continue;
    if (layer.bgra.size() != video_bgr.size() || layer.bgra.type() != CV_32FC4)
      throw Error("overlay '" + options_.layers[i].name + "' has a " + std::to_string(layer.bgra.cols) + "x" +
                      std::to_string(layer.bgra.rows) + " layer for a " + std::to_string(video_bgr.cols) + "x" +
                      std::to_string(video_bgr.rows) + " frame",
                  where(), "render the overlays with the video's calibration (image_size)");
    used_layers[used] = &layer;
    salient[used++] = options_.layers[i].blend == BlendMode::kInverseRealism;
  }
  const bool saliency_needed = std::find(salient.begin(), salient.begin() + used, 1) != salient.begin() + used;
  const int rows = video_bgr.rows, bands = (rows + kBandRows - 1) / kBandRows;
  tbb::parallel_for(tbb::blocked_range<int>(0, bands), [&](const tbb::blocked_range<int>& range) {
    // Kept for the thread's next band. Filled after SaliencyBand, which may wait on a
    // nested parallel loop (OpenCV's, for tiny frames) and so run another band here.
    thread_local cv::Mat saliency;
    thread_local std::vector<const float*> layer_rows;
    for (int band = range.begin(); band < range.end(); ++band) {
      const int y_begin = band * kBandRows, y_end = std::min(rows, y_begin + kBandRows);
      if (saliency_needed) SaliencyBand(video_bgr, options_.inverse_realism, y_begin, y_end, &saliency);
      layer_rows.resize(used);
      for (int y = y_begin; y < y_end; ++y) {
        for (size_t l = 0; l < used; ++l) layer_rows[l] = used_layers[l]->bgra.ptr<float>(y);
        const RowJob job{video_bgr.ptr<std::uint8_t>(y),
                         composite_bgr->ptr<std::uint8_t>(y),
                         video_bgr.cols,
                         layer_rows.data(),
                         salient.data(),
                         static_cast<int>(used),
                         saliency_needed ? saliency.ptr<float>(y - y_begin) : nullptr,
                         options_.inverse_realism.strength};
        ComposeRow(job);
      }
    }
  });
}

}  // namespace dg::stages::overlay
