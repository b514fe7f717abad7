#include "biodyn/mocap_io/file_io.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "biodyn/sim/errors.h"

namespace biodyn::mocap_io {

std::string read_file_bytes(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw sim::InvalidArgument(path + ": cannot read: it is a directory");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw sim::InvalidArgument(path + ": cannot open for reading (" + std::strerror(errno) + ")");
  }
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (in.bad()) throw sim::InvalidArgument(path + ": read error");
  return bytes.str();
}

void write_file_whole(const std::string& path, const std::string& bytes) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) {
      throw sim::Error(path + ": cannot open " + tmp + " for writing (" + std::strerror(errno) +
                       ")");
    }
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    if (!out) {
      std::remove(tmp.c_str());
      throw sim::Error(path + ": write failed");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    std::remove(tmp.c_str());
    throw sim::Error(path + ": cannot rename " + tmp + " over it (" + why + ")");
  }
}

}  // namespace biodyn::mocap_io
