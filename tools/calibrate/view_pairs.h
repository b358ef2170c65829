#pragma once

#include <string>
#include <vector>

#include "tools/calibrate/stereo_calibration.h"

namespace dg::tools::calibrate {

// Pairs the files of two patterns (globs or printf fields, see
// stages::ListImageSequence) in their sorted order.
// @throws dg::Error when either matches nothing or the counts differ.
std::vector<ViewPair> PairsFromPatterns(const std::string& left_pattern, const std::string& right_pattern);

// Pairs the images named left* in a directory with the right* of the same
// suffix (left_03.png with right_03.png, left01.jpg with right01.jpg).
// @throws dg::Error when there is none or a left image has no right one.
std::vector<ViewPair> PairsFromDirectory(const std::string& directory);

}  // namespace dg::tools::calibrate
