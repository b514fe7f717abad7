#pragma once
/// Typed errors of the capture-file readers (style.md, habit 8): every message names the file,
/// where in it (line or byte offset), what was expected and what was found.

#include <string>

#include "biodyn/sim/errors.h"

namespace biodyn::mocap_io {

/// A malformed, truncated or unsupported capture file. Derives from sim::InvalidArgument: a bad
/// input file is bad input (the CLI exits with code 2 and writes nothing).
class ParseError : public sim::InvalidArgument {
 public:
  /// `where` is e.g. "line 12" or "byte 5120"; what() reads
  /// "<file>: <where>: expected <expected>, found <found>".
  ParseError(std::string file, std::string where, std::string expected, std::string found)
      : sim::InvalidArgument(file + ": " + where + ": expected " + expected + ", found " + found),
        file_(std::move(file)),
        where_(std::move(where)),
        expected_(std::move(expected)),
        found_(std::move(found)) {}

  const std::string& file() const { return file_; }
  const std::string& where() const { return where_; }
  const std::string& expected() const { return expected_; }
  const std::string& found() const { return found_; }

  /// "line N" for text formats.
  static std::string line(long number) { return "line " + std::to_string(number); }
  /// "byte N" (0-based offset from the start of the file) for binary formats.
  static std::string byte(long offset) { return "byte " + std::to_string(offset); }

 private:
  std::string file_, where_, expected_, found_;
};

}  // namespace biodyn::mocap_io
