#pragma once

#include <atomic>
#include <exception>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "pipeline/bounded_queue.h"
#include "pipeline/frame_packet.h"
#include "pipeline/mjpeg_avi_writer.h"
#include "pipeline/stage_graph.h"

namespace dg::pipeline {

// How a run's pictures (its annotated video and snapshots) show the stereo
// pair: the left frame alone (W x H), or the left and right frames side by
// side (2W x H), each with its eye's overlays when the run composes them.
enum class VideoLayout { kLeft, kSideBySide };

// The size of a picture of frames of size `eye` in `layout`.
cv::Size LayoutSize(cv::Size eye, VideoLayout layout);

// The packet's picture in `layout` into *picture (its buffer reused when it
// has the size already): each eye's composite, or its captured frame where
// there is none (no overlays, or a left-only run's right eye).
void ArrangePicture(const FramePacket& packet, VideoLayout layout, cv::Mat* picture);

// The video a person watches after a run: the packet's picture in the run's
// layout, with the tracked features drawn in each eye shown (corners green,
// MSER regions orange), the frame's number, time and track count, and, when
// asked, each overlay's layer age (frames since the state it was drawn from). The
// caller (the graph's sink) only copies the picture and the tracks; drawing
// and encoding happen on a thread of its own, off the graph's chain
// (docs/design.md#threads), fed through a bounded blocking queue, so a slow
// encoder never holds the graph in real time: under the realtime policy a
// frame that finds the queue full is dropped and counted; offline the sink
// waits on the queue's condition variable, so the video is complete.
// MJPEG in AVI (MjpegAviWriter): every player and OpenCV opens it. When the
// encoder fails (a full disk), the next Add() throws its error, which stops
// the graph; the frames written before it stay readable.
//
// Lifetime: the constructor opens the file; Start() starts the encoder's
// thread, before the first Add(); Close() drains the
// queue, joins the thread and closes the file. Add() and Close() come from
// one thread (the sink).
class AnnotatedVideo {
 public:
  // @throws dg::Error when the file cannot be opened for writing.
  // eye_size: one camera's frame size (the video is LayoutSize(eye_size, layout)).
  // age_labels: the overlays' names, to label each frame with its layers'
  // ages (packet.layer_age_frames) in that order; empty: no ages shown.
  AnnotatedVideo(const std::string& path, double fps, cv::Size eye_size, VideoLayout layout, Policy policy,
                 std::vector<std::string> age_labels = {}, int queue_frames = 8);
  ~AnnotatedVideo();  // Close()s, logging instead of throwing
  AnnotatedVideo(const AnnotatedVideo&) = delete;
  AnnotatedVideo& operator=(const AnnotatedVideo&) = delete;

  // Starts the encoder's thread. @pre neither started nor closed.
  void Start();
  // Hands the packet's picture and tracks to the encoder. @pre Start()ed.
  // @throws dg::Error after Close(), or the encoder's error once it failed.
  void Add(const FramePacket& packet);
  // Encodes what is queued and closes the file. Idempotent.
  // @throws dg::Error: the encoder's, unless Add() threw it already.
  void Close();

  std::size_t dropped() const { return dropped_.load(); }
  std::int64_t written() const { return written_.load(); }

  // A frame on its way to the encoder: its picture, and what the encoder's
  // thread draws on it.
  struct Frame {
    cv::Mat picture;
    std::vector<stages::TrackedPoint> points;
    std::int64_t index = 0;
    double t_s = 0;
    std::vector<std::int64_t> layer_age_frames;  // only when the ages are shown
  };

 private:
  void Encode();

  std::string path_;
  VideoLayout layout_;
  std::vector<std::string> age_labels_;
  Policy policy_;
  MjpegAviWriter writer_;
  BoundedQueue<Frame> queue_;
  Frame next_;  // the producer's, swapped into the queue
  bool closed_ = false;
  std::atomic<std::size_t> dropped_{0};
  std::atomic<std::int64_t> written_{0};
  std::atomic<bool> failed_{false};
  std::exception_ptr error_;  // the encoder's, set before failed_
  bool error_thrown_ = false;  // by Add() or Close(), the caller's thread
  std::thread encoder_;
};

}  // namespace dg::pipeline
