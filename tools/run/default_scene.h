#pragma once

#include <cstdint>
#include <string>

namespace dg::tools {

// The built-in default scene of `dynaguide run`: the default phantom,
// generated on first use into the cache directory ($DG_CACHE_DIR, else
// $XDG_CACHE_HOME/dynaguide, else ~/.cache/dynaguide) and reused after. A
// generation that was interrupted is not reused: the scene counts only once
// its directory is complete.
// @returns the scene file's path. @throws dg::Error when the cache cannot be written.
std::string DefaultScenePath(bool progress);

// A phantom of a preset and seed, cached the same way (the default scene is
// the default preset's seed 1). @throws dg::Error as DefaultScenePath, or for
// an unknown preset.
std::string CachedPhantomScenePath(const std::string& preset, std::uint64_t seed, bool progress);

}  // namespace dg::tools
