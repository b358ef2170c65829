#include "tools/calibrate/view_pairs.h"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "sim/error.h"
#include "stages/image_sequence.h"

namespace dg::tools::calibrate {
namespace {

namespace fs = std::filesystem;

bool IsImage(const fs::path& path) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  for (const char* known : {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm"}) {
    if (extension == known) return true;
  }
  return false;
}

}  // namespace

std::vector<ViewPair> PairsFromPatterns(const std::string& left_pattern, const std::string& right_pattern) {
  const std::vector<std::string> left = stages::ListImageSequence(left_pattern);
  const std::vector<std::string> right = stages::ListImageSequence(right_pattern);
  if (left.size() != right.size()) {
    throw Error("the left pattern matches " + std::to_string(left.size()) + " files and the right one " +
                    std::to_string(right.size()),
                "--left " + left_pattern + ", --right " + right_pattern,
                "give patterns that match one left and one right image per view");
  }
  std::vector<ViewPair> pairs;
  for (size_t i = 0; i < left.size(); ++i) pairs.push_back({left[i], right[i]});
  return pairs;
}

std::vector<ViewPair> PairsFromDirectory(const std::string& directory) {
  std::vector<ViewPair> pairs;
  for (const std::string& left : stages::ListImageSequence((fs::path(directory) / "left*").string())) {
    if (!IsImage(left)) continue;
    const fs::path right = fs::path(directory) / ("right" + fs::path(left).filename().string().substr(4));
    if (!fs::is_regular_file(right)) {
      throw Error("left image without its right image " + right.string(), left,
                  "add the right image, or remove the left one");
    }
    pairs.push_back({left, right.string()});
  }
  if (pairs.empty()) {
    throw Error("no left* images", directory, "name the pairs left_NN.png and right_NN.png (or .jpg)");
  }
  return pairs;
}

}  // namespace dg::tools::calibrate
