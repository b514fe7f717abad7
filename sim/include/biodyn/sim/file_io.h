#pragma once
/// Whole-file reads and whole-or-nothing writes, for every module: a file a user gave us is
/// read in one go with errors naming it; an output is written into a temporary file beside it
/// and renamed over it, so it is whole or absent.

#include <cstdint>
#include <string>
#include <vector>

namespace biodyn::sim {

/// bytes, the largest file read_file reads: 2 GiB. Generous (the largest capture in
/// ../shared/data is under 2 MB; an hour of 100 markers at 250 Hz in C3D floats is ~1.4 GB) and
/// a bound, so that a wrong path (a huge file, a disk image) fails at once instead of exhausting
/// memory.
inline constexpr std::uintmax_t kMaxInputFileBytes = std::uintmax_t{2} << 30;

/// Suffix of the temporary file write_file_atomically writes before renaming it into place.
inline constexpr const char* kPartialFileSuffix = ".tmp-biodyn";

/// The bytes of the regular file at `path` (symlinks followed). Throws sim::InvalidArgument naming
/// the path if it is not a regular file (a directory, a device such as /dev/zero, a fifo or a
/// socket: none has a size to bound the read), is larger than kMaxInputFileBytes, or cannot be
/// opened or read (a file the user gave us: bad input).
std::string read_file(const std::string& path);

/// What write_file_atomically does about a parent directory that does not exist.
enum class MissingDirectories {
  kError,   ///< sim::Error naming the path (libraries: the caller chose the path)
  kCreate,  ///< create them (command-line outputs go where the user says)
};

/// Writes `bytes` to `path` whole or not at all: into `path` + kPartialFileSuffix, then renamed
/// over it (through a symlink, the file it points to). A path that is a device or pipe
/// (/dev/stdout) is written directly. Throws sim::Error naming the path.
void write_file_atomically(const std::string& path, const std::string& bytes,
                           MissingDirectories missing = MissingDirectories::kError);

/// The fields of one line of a CSV file (or a comma-separated option) split at `separator`, as
/// written: no quoting, no trimming; a trailing separator gives a last empty field ("a,b," has
/// three fields), an empty line none.
std::vector<std::string> split_fields(const std::string& line, char separator = ',');

}  // namespace biodyn::sim
