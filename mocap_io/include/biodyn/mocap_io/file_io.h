#pragma once
/// Whole-file reads and whole-or-nothing writes shared by the capture-file readers and writers.

#include <string>

namespace biodyn::mocap_io {

/// The bytes of the file at `path`. Throws sim::InvalidArgument naming the path if it cannot be
/// opened or read (a file the user gave us: bad input).
std::string read_file_bytes(const std::string& path);

/// Writes `bytes` to `path` whole or not at all: into a temporary file beside it, then renamed
/// over it. Throws sim::Error naming the path if it cannot.
void write_file_whole(const std::string& path, const std::string& bytes);

}  // namespace biodyn::mocap_io
