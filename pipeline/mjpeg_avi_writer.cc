#include "pipeline/mjpeg_avi_writer.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>

#include <opencv2/imgcodecs.hpp>

#include "sim/error.h"
#include "sim/log.h"

namespace dg::pipeline {
namespace {

// The file's layout (Microsoft's AVI RIFF reference; every number little-endian):
//   RIFF 'AVI '
//     LIST 'hdrl'  avih (main header), LIST 'strl' (strh stream header, strf BITMAPINFOHEADER)
//     LIST 'movi'  '00dc' chunks, one a frame, each padded to an even size
//     idx1         one entry a frame: '00dc', keyframe flag, offset from 'movi', size
// Where the counts that Close() fills in sit:
constexpr std::int64_t kRiffSize = 4;
constexpr std::int64_t kAvihMaxBytesPerSecond = 36;
constexpr std::int64_t kAvihTotalFrames = 48;
constexpr std::int64_t kAvihSuggestedBuffer = 60;
constexpr std::int64_t kStrhLength = 140;
constexpr std::int64_t kStrhSuggestedBuffer = 144;
constexpr std::int64_t kMoviSize = 216;
constexpr std::int64_t kMoviType = 220;  // index offsets count from here
constexpr std::int64_t kHeadersEnd = 224;

constexpr std::uint32_t kAvifHasIndex = 0x10;
constexpr char kSpaceFix[] = "free space on the output's file system or choose another --out";
constexpr std::uint32_t kAviifKeyframe = 0x10;

// Bytes of a little-endian header in the making.
class Bytes {
 public:
  Bytes& Four(const char (&code)[5]) {
    bytes_.insert(bytes_.end(), code, code + 4);
    return *this;
  }
  Bytes& U32(std::uint32_t v) {
    for (int i = 0; i < 4; ++i) bytes_.push_back(static_cast<unsigned char>(v >> (8 * i)));
    return *this;
  }
  Bytes& U16(std::uint16_t v) {
    bytes_.push_back(static_cast<unsigned char>(v));
    bytes_.push_back(static_cast<unsigned char>(v >> 8));
    return *this;
  }
  const std::vector<unsigned char>& data() const { return bytes_; }

 private:
  std::vector<unsigned char> bytes_;
};

// fps as rate / scale: exact for whole rates and for the NTSC ones (30000/1001).
void RateAndScale(double fps, std::uint32_t* rate, std::uint32_t* scale) {
  for (std::uint32_t s : {1u, 1001u, 1000u, 1000000u}) {
    const double r = std::round(fps * s);
    if (std::abs(r / s - fps) <= 1e-9 * fps || s == 1000000u) {
      *rate = static_cast<std::uint32_t>(r);
      *scale = s;
      return;
    }
  }
}

}  // namespace

MjpegAviWriter::MjpegAviWriter(const std::string& path, double fps, cv::Size size, int quality)
    : path_(path), size_(size), quality_(quality) {
  if (size.width <= 0 || size.height <= 0 || !(fps > 0 && fps < 1e6)) {
    throw Error("cannot write a video of " + std::to_string(size.width) + "x" + std::to_string(size.height) +
                    " pixels at " + std::to_string(fps) + " frames per second",
                path, "give a positive frame size and rate");
  }
  RateAndScale(fps, &rate_, &scale_);
  file_ = std::fopen(path.c_str(), "wb");
  if (!file_) {
    throw Error(std::string("cannot create the video file: ") + std::strerror(errno), path,
                "check the directory exists and is writable");
  }
  WriteHeaders();
}

MjpegAviWriter::~MjpegAviWriter() {
  try {
    Close();
  } catch (const std::exception& e) {
    Logger("pipeline").error("{}", e.what());
  }
}

void MjpegAviWriter::WriteHeaders() {
  const auto width = static_cast<std::uint32_t>(size_.width), height = static_cast<std::uint32_t>(size_.height);
  Bytes h;
  h.Four("RIFF").U32(0).Four("AVI ");
  h.Four("LIST").U32(192).Four("hdrl");
  h.Four("avih").U32(56);
  h.U32(static_cast<std::uint32_t>(std::lround(1e6 * scale_ / rate_)));  // microseconds a frame
  h.U32(0).U32(0).U32(kAvifHasIndex);  // max bytes a second (Close), padding granularity, flags
  h.U32(0).U32(0).U32(1).U32(0);       // total frames (Close), initial frames, streams, buffer (Close)
  h.U32(width).U32(height).U32(0).U32(0).U32(0).U32(0);
  h.Four("LIST").U32(116).Four("strl");
  h.Four("strh").U32(56).Four("vids").Four("MJPG");
  h.U32(0).U16(0).U16(0).U32(0);  // flags, priority, language, initial frames
  h.U32(scale_).U32(rate_).U32(0).U32(0).U32(0);  // scale, rate, start, length (Close), buffer (Close)
  h.U32(std::numeric_limits<std::uint32_t>::max()).U32(0);  // quality: default; sample size: varies
  h.U16(0).U16(0).U16(static_cast<std::uint16_t>(width)).U16(static_cast<std::uint16_t>(height));
  h.Four("strf").U32(40);
  h.U32(40).U32(width).U32(height).U16(1).U16(24).Four("MJPG").U32(width * height * 3);
  h.U32(0).U32(0).U32(0).U32(0);
  h.Four("LIST").U32(0).Four("movi");
  DG_CHECK(static_cast<std::int64_t>(h.data().size()) == kHeadersEnd);
  WriteBytes(h.data().data(), h.data().size());
}

void MjpegAviWriter::Write(const cv::Mat& bgr) {
  if (!file_) throw Error("the video was closed while frames were still coming", path_, "close it last");
  if (bgr.size() != size_ || bgr.type() != CV_8UC3) {
    throw Error("a frame of " + std::to_string(bgr.cols) + "x" + std::to_string(bgr.rows) + ", type " +
                    std::to_string(bgr.type()) + ", for a video of " + std::to_string(size_.width) + "x" +
                    std::to_string(size_.height) + " 8-bit BGR frames",
                path_, "give every frame the video's size and type");
  }
  if (!cv::imencode(".jpg", bgr, jpeg_, {cv::IMWRITE_JPEG_QUALITY, quality_})) {
    throw Error("the JPEG encoder refused frame " + std::to_string(frames()), path_, "check the frame's data");
  }
  const auto size = static_cast<std::uint32_t>(jpeg_.size());
  const std::uint32_t padded = size + (size & 1);
  // What Close() adds: an index entry a frame and the index's chunk header.
  const std::int64_t closed_end = position_ + 8 + padded + 16 * (frames() + 1) + 8;
  if (closed_end > std::numeric_limits<std::uint32_t>::max()) {
    throw Error("the video reached the AVI format's 4 GiB limit at frame " + std::to_string(frames()), path_,
                "write a shorter range of frames (--frames A:B), or leave the video out (--no-video)");
  }
  index_.push_back({static_cast<std::uint32_t>(position_ - kMoviType), size});
  Bytes chunk;
  chunk.Four("00dc").U32(size);
  WriteBytes(chunk.data().data(), chunk.data().size());
  WriteBytes(jpeg_.data(), jpeg_.size());
  if (padded != size) WriteBytes("", 1);
}

void MjpegAviWriter::Close() {
  if (!file_) return;
  const std::int64_t movi_end = position_;
  Bytes idx1;
  idx1.Four("idx1").U32(static_cast<std::uint32_t>(16 * index_.size()));
  for (const IndexEntry& entry : index_) idx1.Four("00dc").U32(kAviifKeyframe).U32(entry.offset).U32(entry.size);
  WriteBytes(idx1.data().data(), idx1.data().size());
  const auto frames = static_cast<std::uint32_t>(index_.size());
  std::uint32_t largest_frame = 0;
  for (const IndexEntry& entry : index_) largest_frame = std::max(largest_frame, entry.size);
  const double seconds = double(frames) * scale_ / rate_;
  const double bytes_per_second = seconds > 0 ? double(movi_end - kHeadersEnd) / seconds : 0;
  WriteU32At(kRiffSize, static_cast<std::uint32_t>(position_ - 8));
  WriteU32At(kAvihMaxBytesPerSecond, static_cast<std::uint32_t>(std::min(bytes_per_second, 4e9)));
  WriteU32At(kAvihTotalFrames, frames);
  WriteU32At(kAvihSuggestedBuffer, largest_frame + 8);
  WriteU32At(kStrhLength, frames);
  WriteU32At(kStrhSuggestedBuffer, largest_frame + 8);
  WriteU32At(kMoviSize, static_cast<std::uint32_t>(movi_end - kMoviType));
  std::FILE* file = file_;
  file_ = nullptr;
  if (std::fclose(file) != 0) {
    throw Error(std::string("cannot finish the video file: ") + std::strerror(errno), path_, kSpaceFix);
  }
}

void MjpegAviWriter::WriteBytes(const void* data, std::size_t size) {
  if (std::fwrite(data, 1, size, file_) != size) {
    throw Error(std::string("cannot write the video: ") + std::strerror(errno), path_, kSpaceFix);
  }
  position_ += static_cast<std::int64_t>(size);
}

void MjpegAviWriter::WriteU32At(std::int64_t position, std::uint32_t value) {
  Bytes bytes;
  bytes.U32(value);
  if (std::fseek(file_, static_cast<long>(position), SEEK_SET) != 0 ||
      std::fwrite(bytes.data().data(), 1, 4, file_) != 4) {
    throw Error(std::string("cannot write the video's header: ") + std::strerror(errno), path_, kSpaceFix);
  }
}

}  // namespace dg::pipeline
