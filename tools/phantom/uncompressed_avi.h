#pragma once

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace dg::tools::phantom {

// Writes 8-bit BGR frames as an uncompressed AVI (RIFF AVI 1.0, one video
// stream, BI_RGB bottom-up rows, an idx1 index): lossless, as a frame grabber
// records for measurement, and read back by FFmpeg (so cv::VideoCapture), VLC
// and ParaView's movie readers without decoding work. OpenCV's own writers
// offer no lossless uncompressed BGR (their raw video is YUV 4:2:0).
//
// The 32-bit RIFF sizes cap a file at 2 GiB (over two minutes at 640x480,
// 30 fps); beyond that Write() throws, naming the frame and the way out.
class UncompressedAviWriter {
 public:
  // @throws dg::Error when the file cannot be created or the size or rate is invalid.
  UncompressedAviWriter(const std::string& path, cv::Size size, double fps);
  ~UncompressedAviWriter();  // closes, when Close() was not called

  UncompressedAviWriter(const UncompressedAviWriter&) = delete;
  UncompressedAviWriter& operator=(const UncompressedAviWriter&) = delete;

  // @throws dg::Error for a frame of another size or type, or a full file.
  void Write(const cv::Mat& bgr);

  // Writes the index and the sizes the headers promised. @throws dg::Error on an I/O error.
  void Close();

  int frames() const { return frames_; }

 private:
  void WriteHeaders();
  std::streamoff Position() { return static_cast<std::streamoff>(file_.tellp()); }
  void PatchHeaders(std::uint32_t riff_size, std::uint32_t movi_size);

  std::string path_;
  std::ofstream file_;
  cv::Size size_;
  double fps_;
  std::uint32_t row_bytes_;        // 3 * width, padded to 4 bytes
  std::streamoff movi_fourcc_at_;  // where the offsets of idx1 count from
  std::vector<std::uint32_t> chunk_offsets_;
  std::vector<std::uint8_t> frame_buffer_;  // one frame's rows, bottom-up and padded
  int frames_ = 0;
  bool closed_ = false;
};

}  // namespace dg::tools::phantom
