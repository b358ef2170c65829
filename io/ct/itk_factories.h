#pragma once

namespace dg::io {

// Registers ITK's image readers and writers this library uses (GDCM, NIfTI,
// NRRD, MetaImage) with ITK's object factory, once per process. ITK 5 finds
// an image IO only through registered factories; a build that does not
// include ITK's UseITK.cmake (ours: Debian's ITK through imported targets)
// registers none by itself. Thread-safe.
void RegisterItkImageIo();

}  // namespace dg::io
