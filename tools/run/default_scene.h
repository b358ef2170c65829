#pragma once

#include <string>

namespace dg::tools {

// The built-in default scene of `dynaguide run`: the default phantom,
// generated on first use into the cache directory ($DG_CACHE_DIR, else
// $XDG_CACHE_HOME/dynaguide, else ~/.cache/dynaguide) and reused after. A
// generation that was interrupted is not reused: the scene counts only once
// its directory is complete.
// @returns the scene file's path. @throws dg::Error when the cache cannot be written.
std::string DefaultScenePath(bool progress);

}  // namespace dg::tools
