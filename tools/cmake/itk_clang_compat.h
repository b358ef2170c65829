// Forced into every C++ translation unit that clang compiles against ITK
// (CMakeLists.txt).
// Debian's ITK 5.2 ships an itk_compiler_detection.h generated for GCC only:
// under any other compiler it stops at "#error Unsupported compiler". Where
// ITK's headers are on the include path, this reads that header once as GCC 12
// would (its include guard then keeps ITK from reading it again); the feature
// macros it sets (ITK_COMPILER_CXX_*, standard C++11/14 features) hold for
// clang too.
#pragma once

#if defined(__clang__) && __has_include(<itk_compiler_detection.h>)
#pragma push_macro("__clang__")
#pragma push_macro("__GNUC__")
#pragma push_macro("__GNUC_MINOR__")
#undef __clang__
#undef __GNUC__
#undef __GNUC_MINOR__
#define __GNUC__ 12
#define __GNUC_MINOR__ 2
#include <itk_compiler_detection.h>
#pragma pop_macro("__GNUC_MINOR__")
#pragma pop_macro("__GNUC__")
#pragma pop_macro("__clang__")
#endif
