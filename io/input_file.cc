#include "io/input_file.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "sim/error.h"

namespace dg::io {
namespace {

namespace fs = std::filesystem;

const char* KindOf(fs::file_type type) {
  switch (type) {
    case fs::file_type::directory: return "a directory";
    case fs::file_type::fifo: return "a FIFO (named pipe)";
    case fs::file_type::socket: return "a socket";
    case fs::file_type::block: return "a block device";
    case fs::file_type::character: return "a character device";
    default: return "not a regular file";
  }
}

}  // namespace

void RequireRegularFile(const std::string& path, const std::string& what, const std::string& fix) {
  std::error_code error;
  const fs::file_status status = fs::status(path, error);  // follows symbolic links
  if (error || !fs::exists(status)) throw Error("the " + what + " does not exist", path, fix);
  if (!fs::is_regular_file(status)) {
    throw Error("the " + what + " is " + KindOf(status.type()) + ", not a file", path, fix);
  }
}

std::size_t FirstBinaryByte(const char* text, std::size_t size) {
  const auto binary = [](char c) {
    const auto byte = static_cast<unsigned char>(c);
    return (byte < 0x20 && byte != '\t' && byte != '\n' && byte != '\r') || byte == 0x7f;
  };
  return static_cast<std::size_t>(std::find_if(text, text + size, binary) - text);
}

std::string ReadTextFile(const std::string& path, const std::string& what, const std::string& fix,
                         std::size_t max_bytes) {
  RequireRegularFile(path, what, fix);
  std::error_code error;
  const std::uintmax_t size = fs::file_size(path, error);
  if (!error && size > max_bytes) {
    throw Error("the " + what + " is " + std::to_string(size >> 20) + " MiB, too large for a text " + what, path,
                "check the path: give the " + what + " itself, not a data file");
  }
  std::ifstream file(path, std::ios::binary);
  if (!file) throw Error("cannot open the " + what, path, "check that the file is readable");
  std::string text{std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()};
  if (const std::size_t at = FirstBinaryByte(text.data(), text.size()); at < text.size()) {
    const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n');
    char byte[48];
    std::snprintf(byte, sizeof byte, " (byte 0x%02x at offset %zu)", static_cast<unsigned char>(text[at]), at);
    const std::string where = path + ":" + std::to_string(line) + byte;
    throw Error("the " + what + " is not a text file", where,
                "check the path: give the " + what + " (text), not a binary file");
  }
  return text;
}

}  // namespace dg::io
