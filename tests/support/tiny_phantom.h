#pragma once

#include <string>

namespace dg::testing {

// The directory of a `tiny` phantom scene (tools/phantom), generated on first
// call once per test process (test processes run concurrently, so each has
// its own) and removed when the process exits.
const std::string& TinyPhantomDir();

}  // namespace dg::testing
