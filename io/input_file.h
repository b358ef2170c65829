#pragma once

#include <cstddef>
#include <string>

namespace dg::io {

// Checks on an input file before anything reads it, so that a wrong path
// gives a named error instead of a hang or a flood of garbage: a FIFO would
// block the reader, /dev/zero would be read for ever, and a binary file
// given as YAML or .msh would be parsed into messages of raw control bytes.

// @throws dg::Error naming `what` and the path when the path does not exist,
// is a directory, or is not a regular file (a FIFO, socket or device).
void RequireRegularFile(const std::string& path, const std::string& what, const std::string& fix);

// The whole of a text file (YAML, .msh headers): a regular file of at most
// max_bytes holding no control bytes but tab, line feed and carriage return.
// @throws dg::Error naming `what`, the path and, for binary content, the
// offending byte's line and offset.
std::string ReadTextFile(const std::string& path, const std::string& what, const std::string& fix,
                         std::size_t max_bytes = std::size_t(64) << 20);

// The offset of the first byte in [text, text + size) that no text file
// holds (a control byte other than tab, LF, CR), or size when there is none.
std::size_t FirstBinaryByte(const char* text, std::size_t size);

}  // namespace dg::io
