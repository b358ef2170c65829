#pragma once

#include <cstdint>
#include <string>

#include "tools/phantom/beat_options.h"

namespace dg::tools {

// The built-in default scene of `dynaguide run`: the default phantom,
// generated on first use into the cache directory ($DG_CACHE_DIR, else
// $XDG_CACHE_HOME/dynaguide, else ~/.cache/dynaguide) and reused after. A
// generation that was interrupted is not reused: the scene counts only once
// its directory is complete. Processes that ask at once take turns (a lock
// file beside the scene): one generates, the others wait and reuse it.
// @returns the scene file's path. @throws dg::Error when the cache cannot be written.
std::string DefaultScenePath(bool progress);

// A phantom of a preset, seed and beat, cached the same way (the default
// scene is the default preset's seed 1 with the preset's beat).
// @throws dg::Error as DefaultScenePath, or for an unknown preset or an invalid beat.
std::string CachedPhantomScenePath(const std::string& preset, std::uint64_t seed, bool progress,
                                   const phantom::BeatOptions& beat = {});

}  // namespace dg::tools
