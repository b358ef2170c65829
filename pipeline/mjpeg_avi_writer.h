#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace dg::pipeline {

// Motion JPEG in an AVI file: each frame a JPEG compressed by the system's
// libjpeg-turbo (cv::imencode), in a RIFF AVI 1.0 with one video stream and
// an `idx1` index. OpenCV's own MJPEG writer compresses the annotated video's
// frames at under half this speed (docs/commands/run.md, "Speed"), on a core
// the graph shares. OpenCV, FFmpeg (and so VLC and most players) open the
// file. Close() writes the index and the frame counts; a file whose writer
// never closed (the process killed) still has every frame written before,
// which FFmpeg finds by reading the chunks in order.
//
// One thread at a time.
class MjpegAviWriter {
 public:
  // quality: JPEG quality, 1-100. @throws dg::Error when the file cannot be
  // created, or the frame size or rate are not positive.
  MjpegAviWriter(const std::string& path, double fps, cv::Size size, int quality);
  ~MjpegAviWriter();  // Close()s, logging instead of throwing
  MjpegAviWriter(const MjpegAviWriter&) = delete;
  MjpegAviWriter& operator=(const MjpegAviWriter&) = delete;

  // Appends one frame: 8-bit BGR of the writer's size.
  // @throws dg::Error on another size or type, when the disk refuses the
  // bytes, or when the frame would take the file past AVI's 4 GiB.
  void Write(const cv::Mat& bgr);
  // Writes the index and the headers' counts, and closes the file. Idempotent.
  // @throws dg::Error when the disk refuses them.
  void Close();

  std::int64_t frames() const { return static_cast<std::int64_t>(index_.size()); }

 private:
  struct IndexEntry {
    std::uint32_t offset;  // of the chunk, from the `movi` list's type
    std::uint32_t size;    // of its data
  };
  void WriteBytes(const void* data, std::size_t size);
  void WriteU32At(std::int64_t position, std::uint32_t value);
  void WriteHeaders();

  std::string path_;
  std::FILE* file_ = nullptr;
  cv::Size size_;
  int quality_;
  std::uint32_t rate_ = 0, scale_ = 1;  // frames per second = rate / scale
  std::vector<IndexEntry> index_;
  std::vector<unsigned char> jpeg_;  // the frame being written, reused
  std::int64_t position_ = 0;  // where the next byte goes
};

}  // namespace dg::pipeline
