#include "stages/frame_source.h"

#include <filesystem>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "sim/error.h"
#include "stages/image_sequence.h"

namespace dg::stages {
namespace {

std::string SizeText(const cv::Size& size) {
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

class VideoSource : public FrameSource {
 public:
  explicit VideoSource(const std::string& path) : path_(path) {
    // Checked first: VideoCapture only says that it failed, not why.
    if (!std::filesystem::is_regular_file(path)) {
      throw Error("no such video file", path, "check the path");
    }
    if (!capture_.open(path) || !capture_.isOpened()) {
      throw Error("cannot open the video (no backend decodes it)", path,
                  "check that it is a video file; convert it with ffmpeg, e.g. to MJPG in AVI");
    }
    frame_count_ = static_cast<int>(capture_.get(cv::CAP_PROP_FRAME_COUNT));
    fps_ = capture_.get(cv::CAP_PROP_FPS);
    size_ = cv::Size(static_cast<int>(capture_.get(cv::CAP_PROP_FRAME_WIDTH)),
                     static_cast<int>(capture_.get(cv::CAP_PROP_FRAME_HEIGHT)));
    if (frame_count_ <= 0 || size_.area() <= 0) {
      throw Error("the video gives no frame count or frame size", path,
                  "remux it (ffmpeg -i IN -c copy OUT.avi) so that the container states them");
    }
  }

  bool Read(cv::Mat& frame, std::optional<double>* container_t_s) override {
    OwnBuffer(frame);
    if (!capture_.read(frame) || frame.empty()) return false;
    if (frame.size() != size_) {
      throw Error("frame of size " + SizeText(frame.size()) + " in a video of size " + SizeText(size_), path_,
                  "re-encode the video at one frame size");
    }
    const double t_ms = capture_.get(cv::CAP_PROP_POS_MSEC);
    *container_t_s = t_ms >= 0 ? std::optional<double>(t_ms * 1e-3) : std::nullopt;
    return true;
  }

  int frame_count() const override { return frame_count_; }
  double fps() const override { return fps_; }
  cv::Size size() const override { return size_; }
  const std::string& name() const override { return path_; }

 private:
  std::string path_;
  cv::VideoCapture capture_;
  int frame_count_ = 0;
  double fps_ = 0;
  cv::Size size_;
};

class ImageSequenceSource : public FrameSource {
 public:
  explicit ImageSequenceSource(const std::string& pattern)
      : pattern_(pattern), files_(ListImageSequence(pattern)), first_(ReadImage(files_[0])) {
    size_ = first_.size();
  }

  bool Read(cv::Mat& frame, std::optional<double>* container_t_s) override {
    *container_t_s = std::nullopt;
    if (next_ == files_.size()) return false;
    cv::Mat image = next_ == 0 ? first_ : ReadImage(files_[next_]);
    if (next_ == 0) first_ = cv::Mat();  // handed over: not kept alive by the source
    if (image.size() != size_) {
      throw Error("image of size " + SizeText(image.size()) + " in a sequence of size " + SizeText(size_) +
                      " (set by " + files_[0] + ")",
                  files_[next_], "give images of one size");
    }
    ++next_;
    frame = image;
    return true;
  }

  int frame_count() const override { return static_cast<int>(files_.size()); }
  double fps() const override { return 0; }
  cv::Size size() const override { return size_; }
  const std::string& name() const override { return pattern_; }

 private:
  static cv::Mat ReadImage(const std::string& path) {
    cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
    if (image.empty()) throw Error("cannot read image", path, "check that the file is an image");
    return image;
  }

  std::string pattern_;
  std::vector<std::string> files_;
  cv::Mat first_;  // read at opening to learn the size
  cv::Size size_;
  size_t next_ = 0;
};

}  // namespace

void OwnBuffer(cv::Mat& image) {
  // The count only falls while this thread holds its own reference, so a
  // count of one cannot be stale; a stale higher count just costs a buffer.
  if (image.u && image.u->refcount > 1) image.release();
}

std::unique_ptr<FrameSource> OpenVideo(const std::string& path) { return std::make_unique<VideoSource>(path); }

std::unique_ptr<FrameSource> OpenImageSequence(const std::string& pattern) {
  return std::make_unique<ImageSequenceSource>(pattern);
}

}  // namespace dg::stages
