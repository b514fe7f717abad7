// Whole-file reads are bounded: a device, a fifo or a file over kMaxInputFileBytes is refused
// at once, naming the path, instead of growing without bound (issue 24, defect 9).
#include "biodyn/sim/file_io.h"

#include <sys/stat.h>

#include <filesystem>
#include <fstream>

#include "biodyn/sim/errors.h"
#include "test_support.h"

using namespace biodyn;
using Catch::Matchers::Contains;

namespace {

/// An empty scratch directory of this file's tests.
std::filesystem::path file_io_scratch(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::path(testing::binary_dir()) / "sim_test_files" / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

/// read_file(path) throws sim::InvalidArgument whose message names the path and holds `words`.
void require_read_refused(const std::string& path, const std::string& words) {
  try {
    sim::read_file(path);
    FAIL("read_file(" << path << ") did not throw");
  } catch (const sim::InvalidArgument& e) {
    CHECK_THAT(e.what(), Contains(path) && Contains(words));
  }
}

}  // namespace

TEST_CASE("read_file reads a regular file whole, through a symlink too", "[sim][file_io]") {
  const std::filesystem::path dir = file_io_scratch("regular");
  const std::string bytes("a\0b\nc", 5);
  std::ofstream(dir / "f.txt", std::ios::binary) << bytes;
  CHECK(sim::read_file((dir / "f.txt").string()) == bytes);
  std::filesystem::create_symlink(dir / "f.txt", dir / "link.txt");
  CHECK(sim::read_file((dir / "link.txt").string()) == bytes);
  std::ofstream(dir / "empty.txt").flush();
  CHECK(sim::read_file((dir / "empty.txt").string()).empty());
  require_read_refused((dir / "missing.txt").string(), "cannot open");
  require_read_refused(dir.string(), "directory");
}

TEST_CASE("read_file refuses devices and fifos, through a symlink too", "[sim][file_io]") {
  const std::filesystem::path dir = file_io_scratch("devices");
  // /dev/zero never ends: read to its end it would take all memory.
  std::filesystem::create_symlink("/dev/zero", dir / "zeros.c3d");
  require_read_refused((dir / "zeros.c3d").string(), "character device");
  // A fifo without a writer would block the open; refused before opening.
  const std::filesystem::path fifo = dir / "pipe.trc";
  REQUIRE(mkfifo(fifo.c_str(), 0600) == 0);
  require_read_refused(fifo.string(), "fifo");
}

TEST_CASE("read_file refuses a file over kMaxInputFileBytes without reading it", "[sim][file_io]") {
  const std::filesystem::path dir = file_io_scratch("huge");
  const std::filesystem::path huge = dir / "huge.bvh";
  std::ofstream(huge).flush();
  // Sparse: takes no disk space and no time to make.
  std::filesystem::resize_file(huge, sim::kMaxInputFileBytes + 1);
  require_read_refused(huge.string(), std::to_string(sim::kMaxInputFileBytes + 1) + " bytes");
  std::filesystem::remove(huge);
}
