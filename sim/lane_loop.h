#pragma once

// Put before a loop over the lanes of an element block whose iterations
// read and write different lanes only: GCC then vectorizes it without
// proving that the block's pointers do not alias one another. Clang has no
// such pragma and would warn on GCC's; its builds (the test suite's second
// compiler) get an empty mark and vectorize only what their own alias
// analysis proves safe.
#if defined(__clang__)
#define DG_LANE_LOOP
#else
#define DG_LANE_LOOP _Pragma("GCC ivdep")
#endif
