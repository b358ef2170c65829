#include "tools/phantom/uncompressed_avi.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "sim/error.h"

namespace dg::tools::phantom {
namespace {

constexpr std::uint64_t kMaxFileBytes = std::uint64_t{1} << 31;  // 2 GiB: readers' signed 32-bit offsets
constexpr std::uint32_t kHasIndex = 0x10;                       // AVIF_HASINDEX
constexpr std::uint32_t kKeyFrame = 0x10;                       // AVIIF_KEYFRAME
constexpr char kFrameChunk[] = "00db";                          // stream 0, uncompressed DIB

// RIFF is little-endian whatever the host is.
void PutU32(std::vector<std::uint8_t>* out, std::uint32_t value) {
  for (int byte = 0; byte < 4; ++byte) out->push_back(static_cast<std::uint8_t>(value >> (8 * byte)));
}
void PutU16(std::vector<std::uint8_t>* out, std::uint16_t value) {
  out->push_back(static_cast<std::uint8_t>(value));
  out->push_back(static_cast<std::uint8_t>(value >> 8));
}
void PutFourcc(std::vector<std::uint8_t>* out, const char* fourcc) { out->insert(out->end(), fourcc, fourcc + 4); }

// The rate as dwRate / dwScale: exact for integer rates, to 1/1000 fps otherwise.
std::pair<std::uint32_t, std::uint32_t> RateAndScale(double fps) {
  if (fps == std::round(fps)) return {static_cast<std::uint32_t>(fps), 1};
  return {static_cast<std::uint32_t>(std::lround(fps * 1000)), 1000};
}

}  // namespace

UncompressedAviWriter::UncompressedAviWriter(const std::string& path, cv::Size size, double fps)
    : path_(path), size_(size), fps_(fps), row_bytes_((3 * size.width + 3) & ~3u) {
  if (size.width <= 0 || size.height <= 0 || !(fps > 0) || !std::isfinite(fps)) {
    throw Error("invalid video size " + std::to_string(size.width) + "x" + std::to_string(size.height) +
                    " or rate " + std::to_string(fps) + " fps",
                path, "give a positive frame size and frame rate");
  }
  file_.open(path, std::ios::binary | std::ios::trunc);
  if (!file_) throw Error("cannot create the video file", path, "check that the folder exists and is writable");
  frame_buffer_.resize(std::size_t{row_bytes_} * size.height, 0);
  WriteHeaders();
}

UncompressedAviWriter::~UncompressedAviWriter() {
  try {
    Close();
  } catch (...) {  // a destructor must not throw; Close() reports errors to callers that ask
  }
}

// RIFF('AVI ' LIST('hdrl' avih LIST('strl' strh strf)) LIST('movi' ...) idx1).
// Sizes and frame counts are written as 0 here and patched by Close().
void UncompressedAviWriter::WriteHeaders() {
  const auto [rate, scale] = RateAndScale(fps_);
  const std::uint32_t frame_bytes = static_cast<std::uint32_t>(frame_buffer_.size());
  std::vector<std::uint8_t> h;
  PutFourcc(&h, "RIFF");
  PutU32(&h, 0);  // patched
  PutFourcc(&h, "AVI ");
  PutFourcc(&h, "LIST");
  PutU32(&h, 4 + (8 + 56) + (12 + (8 + 56) + (8 + 40)));
  PutFourcc(&h, "hdrl");
  PutFourcc(&h, "avih");
  PutU32(&h, 56);
  PutU32(&h, static_cast<std::uint32_t>(std::lround(1e6 / fps_)));  // microseconds per frame
  PutU32(&h, static_cast<std::uint32_t>(std::min(4.0e9, frame_bytes * fps_)));  // max bytes per second
  PutU32(&h, 0);          // padding granularity
  PutU32(&h, kHasIndex);  // flags
  PutU32(&h, 0);          // total frames: patched (offset 48)
  PutU32(&h, 0);          // initial frames
  PutU32(&h, 1);          // streams
  PutU32(&h, frame_bytes);
  PutU32(&h, size_.width);
  PutU32(&h, size_.height);
  for (int i = 0; i < 4; ++i) PutU32(&h, 0);
  PutFourcc(&h, "LIST");
  PutU32(&h, 4 + (8 + 56) + (8 + 40));
  PutFourcc(&h, "strl");
  PutFourcc(&h, "strh");
  PutU32(&h, 56);
  PutFourcc(&h, "vids");
  PutFourcc(&h, "DIB ");
  PutU32(&h, 0);  // flags
  PutU16(&h, 0);  // priority
  PutU16(&h, 0);  // language
  PutU32(&h, 0);  // initial frames
  PutU32(&h, scale);
  PutU32(&h, rate);
  PutU32(&h, 0);  // start
  PutU32(&h, 0);  // length in frames: patched (offset 140)
  PutU32(&h, frame_bytes);
  PutU32(&h, 0xFFFFFFFFu);  // quality: default
  PutU32(&h, 0);            // sample size: varies (one frame a chunk)
  for (int v : {0, 0, size_.width, size_.height}) PutU16(&h, static_cast<std::uint16_t>(v));
  PutFourcc(&h, "strf");
  PutU32(&h, 40);  // BITMAPINFOHEADER
  PutU32(&h, 40);
  PutU32(&h, size_.width);
  PutU32(&h, size_.height);  // positive: rows bottom-up
  PutU16(&h, 1);             // planes
  PutU16(&h, 24);            // bits per pixel
  PutU32(&h, 0);             // BI_RGB
  PutU32(&h, frame_bytes);
  for (int i = 0; i < 4; ++i) PutU32(&h, 0);
  PutFourcc(&h, "LIST");
  PutU32(&h, 0);  // patched
  movi_fourcc_at_ = static_cast<std::streamoff>(h.size());
  PutFourcc(&h, "movi");
  file_.write(reinterpret_cast<const char*>(h.data()), static_cast<std::streamsize>(h.size()));
}

void UncompressedAviWriter::Write(const cv::Mat& bgr) {
  if (closed_) throw Error("the video was closed already", path_, "write every frame before Close()");
  if (bgr.type() != CV_8UC3 || bgr.size() != size_) {
    throw Error("frame " + std::to_string(frames_) + " is not 8-bit BGR of " + std::to_string(size_.width) + "x" +
                    std::to_string(size_.height),
                path_, "give every frame the size and type the video was opened with");
  }
  const std::uint64_t end = static_cast<std::uint64_t>(Position()) + 8 + frame_buffer_.size() +
                            16ull * (frames_ + 1);  // the index grows too
  if (end >= kMaxFileBytes) {
    throw Error("frame " + std::to_string(frames_) + " would take the uncompressed video past 2 GiB", path_,
                "record a shorter video, or a compressed lossless one (dynaguide phantom --codec huffyuv)");
  }
  for (int row = 0; row < size_.height; ++row) {
    std::memcpy(&frame_buffer_[std::size_t{row_bytes_} * (size_.height - 1 - row)], bgr.ptr(row), 3 * size_.width);
  }
  chunk_offsets_.push_back(static_cast<std::uint32_t>(Position() - movi_fourcc_at_));
  std::vector<std::uint8_t> chunk_header;
  PutFourcc(&chunk_header, kFrameChunk);
  PutU32(&chunk_header, static_cast<std::uint32_t>(frame_buffer_.size()));
  file_.write(reinterpret_cast<const char*>(chunk_header.data()), 8);
  file_.write(reinterpret_cast<const char*>(frame_buffer_.data()), static_cast<std::streamsize>(frame_buffer_.size()));
  if (!file_) throw Error("cannot write frame " + std::to_string(frames_), path_, "check the free disk space");
  ++frames_;
}

void UncompressedAviWriter::Close() {
  if (closed_) return;
  closed_ = true;
  const std::uint32_t movi_size = static_cast<std::uint32_t>(Position() - movi_fourcc_at_);
  std::vector<std::uint8_t> index;
  PutFourcc(&index, "idx1");
  PutU32(&index, static_cast<std::uint32_t>(16 * chunk_offsets_.size()));
  for (std::uint32_t offset : chunk_offsets_) {
    PutFourcc(&index, kFrameChunk);
    PutU32(&index, kKeyFrame);
    PutU32(&index, offset);
    PutU32(&index, static_cast<std::uint32_t>(frame_buffer_.size()));
  }
  file_.write(reinterpret_cast<const char*>(index.data()), static_cast<std::streamsize>(index.size()));
  const std::uint32_t riff_size = static_cast<std::uint32_t>(Position() - 8);
  PatchHeaders(riff_size, movi_size);
  file_.close();
  if (!file_) throw Error("cannot finish the video file", path_, "check the free disk space");
}

void UncompressedAviWriter::PatchHeaders(std::uint32_t riff_size, std::uint32_t movi_size) {
  auto patch = [this](std::streamoff at, std::uint32_t value) {
    std::vector<std::uint8_t> bytes;
    PutU32(&bytes, value);
    file_.seekp(at);
    file_.write(reinterpret_cast<const char*>(bytes.data()), 4);
  };
  patch(4, riff_size);
  patch(48, static_cast<std::uint32_t>(frames_));   // avih total frames
  patch(140, static_cast<std::uint32_t>(frames_));  // strh length
  patch(movi_fourcc_at_ - 4, movi_size);
  file_.seekp(0, std::ios::end);
}

}  // namespace dg::tools::phantom
