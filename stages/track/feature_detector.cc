#include "stages/track/feature_detector.h"

#include <algorithm>
#include <cmath>

#include <opencv2/features2d.hpp>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <opencv2/imgproc.hpp>

#include "sim/error.h"
#include "stages/track/region_moments.h"

namespace dg::stages {
namespace {

// Cells of side min_distance: a new point need only look at the 3x3 cells around it.
class OccupancyGrid {
 public:
  OccupancyGrid(cv::Size size, double min_distance)
      : cell_(std::max(1.0, min_distance)),
        min_distance2_(min_distance * min_distance),
        cols_(static_cast<int>(size.width / cell_) + 1),
        rows_(static_cast<int>(size.height / cell_) + 1),
        cells_(static_cast<size_t>(cols_) * rows_) {}

  bool Free(const cv::Point2f& p) const {
    const int cx = static_cast<int>(p.x / cell_), cy = static_cast<int>(p.y / cell_);
    for (int y = std::max(0, cy - 1); y <= std::min(rows_ - 1, cy + 1); ++y) {
      for (int x = std::max(0, cx - 1); x <= std::min(cols_ - 1, cx + 1); ++x) {
        for (const cv::Point2f& q : cells_[y * cols_ + x]) {
          const cv::Point2f d = p - q;
          if (d.dot(d) < min_distance2_) return false;
        }
      }
    }
    return true;
  }

  void Add(const cv::Point2f& p) {
    const int cx = std::clamp(static_cast<int>(p.x / cell_), 0, cols_ - 1);
    const int cy = std::clamp(static_cast<int>(p.y / cell_), 0, rows_ - 1);
    cells_[cy * cols_ + cx].push_back(p);
  }

 private:
  double cell_, min_distance2_;
  int cols_, rows_;
  std::vector<std::vector<cv::Point2f>> cells_;
};

}  // namespace

std::string FeatureDetector::Options::Validate() const {
  if (!corners && !mser) return "corners and mser are both off: enable at least one detector";
  if (target_count <= 0) return "target_count must be positive";
  if (grid_cols <= 0 || grid_rows <= 0) return "grid_cols and grid_rows must be positive";
  if (border_px < 0) return "border_px must not be negative";
  if (min_distance_px < 0) return "min_distance_px must not be negative";
  if (corner_quality <= 0 || corner_quality >= 1) return "corner_quality must be in (0, 1)";
  if (corner_block_size < 3 || corner_block_size % 2 == 0) return "corner_block_size must be odd and at least 3";
  if (mser_delta <= 0) return "mser_delta must be positive";
  if (mser_min_area_px <= 0 || mser_max_area_px <= mser_min_area_px)
    return "need 0 < mser_min_area_px < mser_max_area_px";
  if (mser_max_elongation < 1) return "mser_max_elongation must be at least 1";
  return {};
}

FeatureDetector::FeatureDetector(const Options& options) : options_(options) {
  if (const std::string error = options.Validate(); !error.empty())
    throw Error("invalid feature detector options: " + error, "FeatureDetector::Options", "correct the option");
}

std::vector<Feature> FeatureDetector::DetectCorners(const cv::Mat& image) const {
  return DetectCorners(image, [](const cv::Point2f&) { return true; });
}

std::vector<Feature> FeatureDetector::DetectCorners(const cv::Mat& image,
                                                    const std::function<bool(const cv::Point2f&)>& wanted) const {
  DG_CHECK(image.type() == CV_8UC1);
  cv::Mat response;
  cv::cornerMinEigenVal(image, response, options_.corner_block_size, 3);
  // Local maxima above the quality threshold: the candidates goodFeaturesToTrack
  // would consider, but with their responses kept for the buckets.
  double max_response = 0;
  cv::minMaxLoc(response, nullptr, &max_response);
  cv::Mat dilated;
  cv::dilate(response, dilated, cv::Mat());
  const float threshold = static_cast<float>(options_.corner_quality * max_response);
  std::vector<Feature> features;
  const int b = options_.border_px;
  for (int y = b; y < image.rows - b; ++y) {
    const float* r = response.ptr<float>(y);
    const float* d = dilated.ptr<float>(y);
    for (int x = b; x < image.cols - b; ++x) {
      if (r[x] > threshold && r[x] == d[x] && wanted(cv::Point2f(static_cast<float>(x), static_cast<float>(y)))) {
        Feature f;
        f.uv_R_px = cv::Point2f(static_cast<float>(x), static_cast<float>(y));
        f.kind = FeatureKind::kCorner;
        f.ellipse = cv::RotatedRect(f.uv_R_px, cv::Size2f(0, 0), 0);
        f.score = r[x];
        features.push_back(f);
      }
    }
  }
  if (features.empty()) return features;
  // Sub-pixel corner positions: the stereo matcher searches from them.
  std::vector<cv::Point2f> points;
  for (const Feature& f : features) points.push_back(f.uv_R_px);
  cv::cornerSubPix(image, points, cv::Size(3, 3), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 10, 0.01));
  for (size_t i = 0; i < features.size(); ++i) features[i].uv_R_px = points[i];
  return features;
}

std::vector<Feature> FeatureDetector::DetectMser(const cv::Mat& image) const {
  DG_CHECK(image.type() == CV_8UC1);
  cv::Ptr<cv::MSER> mser = cv::MSER::create(options_.mser_delta, options_.mser_min_area_px, options_.mser_max_area_px);
  std::vector<std::vector<cv::Point>> regions;
  std::vector<cv::Rect> boxes;
  mser->detectRegions(image, regions, boxes);
  std::vector<Feature> features;
  const float b = static_cast<float>(options_.border_px);
  for (const std::vector<cv::Point>& region : regions) {
    RegionMoments moments;
    for (const cv::Point& p : region) moments.Add(p.x, p.y);
    if (!moments.Compact(options_.mser_max_elongation)) continue;
    double major, minor, angle_deg;
    moments.PrincipalAxes(&major, &minor, &angle_deg);
    const cv::Point2f centre = moments.centroid();
    if (centre.x < b || centre.y < b || centre.x >= image.cols - b || centre.y >= image.rows - b) continue;
    Feature f;
    f.uv_R_px = centre;
    f.kind = FeatureKind::kMser;
    f.ellipse = cv::RotatedRect(centre, cv::Size2f(float(4 * std::sqrt(major)), float(4 * std::sqrt(minor))),
                                static_cast<float>(angle_deg));
    // Round regions localise equally well in both directions.
    f.score = static_cast<float>(std::sqrt(minor / major));
    features.push_back(f);
  }
  return features;
}

std::vector<Feature> FeatureDetector::DetectMserIn(const cv::Mat& image, const cv::Rect& bucket) const {
  // The margin holds whole every region centred in the bucket that the
  // filters keep (area and elongation bounded), and the border the matchers need.
  const double longest_semi_axis =
      std::sqrt(options_.mser_max_area_px * options_.mser_max_elongation / CV_PI);
  const int margin = std::max(options_.border_px, static_cast<int>(std::ceil(longest_semi_axis)) + 1);
  const cv::Rect tile = (bucket + cv::Size(2 * margin, 2 * margin) - cv::Point(margin, margin)) &
                        cv::Rect(0, 0, image.cols, image.rows);
  std::vector<Feature> features;
  for (Feature f : DetectMser(image(tile))) {
    f.uv_R_px += cv::Point2f(static_cast<float>(tile.x), static_cast<float>(tile.y));
    f.ellipse.center = f.uv_R_px;
    if (bucket.contains(cv::Point(static_cast<int>(f.uv_R_px.x), static_cast<int>(f.uv_R_px.y))))
      features.push_back(f);
  }
  return features;
}

std::vector<Feature> FeatureDetector::Detect(const cv::Mat& image, const std::vector<cv::Point2f>& existing) const {
  const int buckets = options_.grid_cols * options_.grid_rows;
  const int quota = (options_.target_count + buckets - 1) / buckets;
  const auto bucket_of = [&](const cv::Point2f& p) {
    const int col = std::clamp(static_cast<int>(p.x * options_.grid_cols / image.cols), 0, options_.grid_cols - 1);
    const int row = std::clamp(static_cast<int>(p.y * options_.grid_rows / image.rows), 0, options_.grid_rows - 1);
    return row * options_.grid_cols + col;
  };
  OccupancyGrid occupancy(image.size(), options_.min_distance_px);
  std::vector<int> filled(buckets, 0);
  for (const cv::Point2f& p : existing) {
    occupancy.Add(p);
    ++filled[bucket_of(p)];
  }

  std::vector<cv::Rect> needy;  // the buckets short of their share
  for (int i = 0; i < buckets; ++i) {
    if (filled[i] >= quota) continue;
    const int col = i % options_.grid_cols, row = i / options_.grid_cols;
    const cv::Point tl(col * image.cols / options_.grid_cols, row * image.rows / options_.grid_rows);
    const cv::Point br((col + 1) * image.cols / options_.grid_cols, (row + 1) * image.rows / options_.grid_rows);
    needy.emplace_back(tl, br);
  }
  if (needy.empty()) return {};
  const auto in_needy = [&](const cv::Point2f& p) { return filled[bucket_of(p)] < quota; };

  // Candidates only in the buckets short of their share, both kinds at once.
  // Corners come from the whole image (cheap, and their quality threshold is
  // relative to the image's strongest response); MSER, the expensive one,
  // runs on the whole image only when most buckets are short (the first
  // frame) and otherwise on a tile around each short bucket, tiles in parallel.
  std::vector<std::vector<Feature>> kinds;
  std::vector<Feature> corners, regions;
  tbb::parallel_invoke(
      [&] {
        if (options_.corners) corners = DetectCorners(image, in_needy);
      },
      [&] {
        if (!options_.mser) return;
        if (2 * needy.size() > static_cast<size_t>(buckets)) {
          regions = DetectMser(image);
          return;
        }
        std::vector<std::vector<Feature>> per_tile(needy.size());
        tbb::parallel_for(size_t{0}, needy.size(), [&](size_t t) { per_tile[t] = DetectMserIn(image, needy[t]); });
        for (std::vector<Feature>& tile : per_tile) regions.insert(regions.end(), tile.begin(), tile.end());
      });
  if (options_.corners) kinds.push_back(std::move(corners));
  if (options_.mser) kinds.push_back(std::move(regions));
  // Each enabled kind gets its share of every bucket, so that neither kind
  // crowds out the other where both are plentiful.
  std::vector<Feature> selected;
  for (size_t k = 0; k < kinds.size(); ++k) {
    std::vector<Feature>& candidates = kinds[k];
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const Feature& a, const Feature& b) { return a.score > b.score; });
    const int remaining_kinds = static_cast<int>(kinds.size() - k);
    std::vector<int> limit(buckets);
    for (int i = 0; i < buckets; ++i) limit[i] = filled[i] + (quota - filled[i] + remaining_kinds - 1) / remaining_kinds;
    for (const Feature& f : candidates) {
      const int bucket = bucket_of(f.uv_R_px);
      if (filled[bucket] >= limit[bucket] || !occupancy.Free(f.uv_R_px)) continue;
      occupancy.Add(f.uv_R_px);
      ++filled[bucket];
      selected.push_back(f);
    }
  }
  // Buckets without texture (background, specular highlights) leave their
  // share unused: hand it to the textured ones, best response first, so the
  // count still reaches the target.
  int total = static_cast<int>(existing.size() + selected.size());
  for (const std::vector<Feature>& candidates : kinds) {
    for (const Feature& f : candidates) {
      if (total >= options_.target_count) return selected;
      if (!occupancy.Free(f.uv_R_px)) continue;
      occupancy.Add(f.uv_R_px);
      selected.push_back(f);
      ++total;
    }
  }
  return selected;
}

}  // namespace dg::stages
