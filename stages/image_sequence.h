#pragma once

#include <string>
#include <vector>

namespace dg::stages {

// The files of an image sequence, in frame order. The pattern names files in
// one directory by either
//  - a printf integer ("frames/left_%04d.png", "left_%d.png"): the files whose
//    number fills that field, sorted by number, which must be consecutive
//    (a gap would shift every later frame's time); or
//  - a glob (* ? [...] in the file name, "frames/left_*.png"): sorted by name.
// A pattern with neither names one file.
// @throws dg::Error when the directory does not exist, nothing matches, or
// the numbers have a gap (naming the first missing file).
std::vector<std::string> ListImageSequence(const std::string& pattern);

}  // namespace dg::stages
