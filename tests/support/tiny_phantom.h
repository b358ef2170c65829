#pragma once

#include <string>

namespace dg::testing {

// The directory of a `tiny` phantom scene (tools/phantom), made on first call
// once per test process (test processes run concurrently, so each has its
// own) and removed when the process exits. Under ctest it is a copy of the
// scene the fixture tiny_phantom generated once for the run (the directory in
// DG_TINY_PHANTOM_DIR); without that variable, as when a test executable runs
// by hand, the process generates the scene itself.
const std::string& TinyPhantomDir();

}  // namespace dg::testing
