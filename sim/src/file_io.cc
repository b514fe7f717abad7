// Whole-file reads and whole-or-nothing writes (file_io.h).
#include "biodyn/sim/file_io.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "biodyn/sim/errors.h"

namespace biodyn::sim {
namespace {

/// What a file that is not a regular file is, for messages.
const char* file_kind(std::filesystem::file_type type) {
  switch (type) {
    case std::filesystem::file_type::block:
      return "a block device";
    case std::filesystem::file_type::character:
      return "a character device";
    case std::filesystem::file_type::fifo:
      return "a fifo (pipe)";
    case std::filesystem::file_type::socket:
      return "a socket";
    default:
      return "not a regular file";
  }
}

/// "at most 2 GiB (2147483648 bytes)": kMaxInputFileBytes, for messages.
std::string input_limit_text() {
  return "at most " + std::to_string(kMaxInputFileBytes >> 30) + " GiB (" +
         std::to_string(kMaxInputFileBytes) + " bytes)";
}

}  // namespace

std::string read_file(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  // status() follows symlinks: a link to /dev/zero is the device it names.
  const fs::file_status status = fs::status(path, ec);
  if (fs::is_directory(status)) {
    throw sim::InvalidArgument(path + ": cannot read: it is a directory");
  }
  if (!ec && fs::exists(status) && !fs::is_regular_file(status)) {
    throw sim::InvalidArgument(path + ": cannot read: expected a regular file, found " +
                               file_kind(status.type()) + " (no size bounds what it gives)");
  }
  std::uintmax_t size = 0;
  if (!ec && fs::exists(status)) size = fs::file_size(path, ec);
  if (!ec && size > kMaxInputFileBytes) {
    throw sim::InvalidArgument(path + ": cannot read: expected a file of " + input_limit_text() +
                               ", found " + std::to_string(size) + " bytes");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw sim::InvalidArgument(path + ": cannot open for reading (" + std::strerror(errno) + ")");
  }
  // Stops once past the bound: a file that grew after the size check is refused all the same.
  std::string bytes;
  bytes.reserve(static_cast<std::size_t>(size));
  constexpr std::size_t kChunkBytes = std::size_t{1} << 20;
  std::string chunk(kChunkBytes, '\0');
  while (in) {
    in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    bytes.append(chunk.data(), static_cast<std::size_t>(in.gcount()));
    if (bytes.size() > kMaxInputFileBytes) {
      throw sim::InvalidArgument(path + ": cannot read: expected a file of " + input_limit_text() +
                                 ", found more (it grew while read)");
    }
  }
  if (in.bad()) throw sim::InvalidArgument(path + ": read error");
  return bytes;
}

void write_file_atomically(const std::string& path, const std::string& bytes,
                           MissingDirectories missing) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path target(path);
  const fs::file_status status = fs::status(target, ec);
  if (fs::exists(status) && !fs::is_regular_file(status)) {
    // A device or pipe (/dev/stdout, a fifo): stream into it; renaming over it would replace it.
    if (fs::is_directory(status)) throw sim::Error(path + ": is a directory");
    std::ofstream out(target, std::ios::binary);
    if (!(out << bytes) || !out.flush()) throw sim::Error(path + ": write failed");
    return;
  }
  // Keep a symlink (even a dangling one) and write the file it points to.
  for (int hops = 0; hops < 40 && fs::is_symlink(fs::symlink_status(target, ec)); ++hops) {
    const fs::path next = fs::read_symlink(target, ec);
    if (ec) break;
    target = next.is_absolute() ? next : target.parent_path() / next;
  }
  if (target.has_parent_path() && missing == MissingDirectories::kCreate) {
    fs::create_directories(target.parent_path(), ec);
    if (ec) throw sim::Error(path + ": cannot create directory: " + ec.message());
  }
  const fs::path tmp = target.string() + kPartialFileSuffix;
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw sim::Error(path + ": cannot open for writing");
    out << bytes;
    out.flush();
    if (!out) {
      out.close();
      fs::remove(tmp, ec);
      throw sim::Error(path + ": write failed");
    }
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    std::error_code ignore;
    fs::remove(tmp, ignore);
    throw sim::Error(path + ": cannot move the finished file into place: " + ec.message());
  }
}

std::vector<std::string> split_fields(const std::string& line, char separator) {
  std::vector<std::string> out;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, separator)) out.push_back(field);
  if (!line.empty() && line.back() == separator) out.emplace_back();
  return out;
}

}  // namespace biodyn::sim
