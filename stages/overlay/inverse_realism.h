#pragma once

#include <string>

#include <opencv2/core/mat.hpp>

namespace dg::stages::overlay {

// Inverse Realism (Lerotic, Chung, Mylonas, Yang, MICCAI 2007): drawn
// internal anatomy looks like it lies beneath the tissue when the video's own
// surface cues stay on top of it. A saliency map of the frame, in [0, 1],
//   s = clamp(w_edge e + w_detail t + w_highlight h),
//   e = |grad G| / edge_scale      (G the grey frame, Gaussian-smoothed),
//   t = |G - blur(G)| / detail_scale   (fine texture),
//   h = ramp(V, highlight_lo, highlight_hi) (1 - S)   (specular highlights:
//       bright and unsaturated; V, S of HSV),
// keeps the video where it is salient: a layer's effective opacity becomes
// alpha (1 - strength s). The paper derives its cues from pq-space
// curvature of the recovered surface; these image-space cues (edges, fine
// texture, highlights) are the ones the issue names, computed per frame in
// about a millisecond.
struct InverseRealismOptions {
  float w_edge = 1.0f, w_detail = 0.6f, w_highlight = 1.0f;
  float edge_scale = 0.25f;   // grey levels (of 1) per pixel of gradient for full saliency
  float detail_scale = 0.06f; // grey levels of fine texture for full saliency
  float highlight_lo = 0.75f, highlight_hi = 0.95f;
  float strength = 0.85f;     // of the saliency taken off the overlay's opacity
  // Empty when valid; otherwise what is wrong.
  std::string Validate() const;
};

// CV_32FC1 saliency in [0, 1] of a CV_8UC3 BGR frame.
// @throws dg::Error if the frame is not 8-bit BGR.
cv::Mat Saliency(const cv::Mat& frame_bgr, const InverseRealismOptions& options);

// Rows [y_begin, y_end) of Saliency(frame_bgr, options), the same values, into
// *band ((y_end - y_begin) x cols CV_32FC1; created unless it already is, so a
// caller that keeps it allocates nothing). For callers that fuse the saliency
// with their own per-row work a band at a time (the compositor); each band is
// computed from the frame alone, so bands may run on any threads at once.
// Allocates nothing once the calling thread has run a band of this size.
// @pre 0 <= y_begin < y_end <= frame_bgr.rows.
// @throws dg::Error if the frame is not 8-bit BGR.
void SaliencyBand(const cv::Mat& frame_bgr, const InverseRealismOptions& options, int y_begin, int y_end,
                  cv::Mat* band);

}  // namespace dg::stages::overlay
