#define CATCH_CONFIG_MAIN
#include "test_support.h"

#include <cstdlib>
#include <mutex>

#include "biodyn/sim/errors.h"

namespace biodyn::testing {
namespace {
std::mutex g_mutex;
std::vector<std::string> g_messages;
}  // namespace

MujocoWarningGuard::MujocoWarningGuard() {
  {
    std::lock_guard<std::mutex> lock(g_mutex);
    g_messages.clear();
  }
  previous_ = sim::set_log_sink([](sim::LogLevel level, std::string_view msg) {
    if (level == sim::LogLevel::kWarning || level == sim::LogLevel::kError) {
      std::lock_guard<std::mutex> lock(g_mutex);
      g_messages.emplace_back(msg);
    }
  });
}

MujocoWarningGuard::~MujocoWarningGuard() {
  sim::set_log_sink(std::move(previous_));
  std::lock_guard<std::mutex> lock(g_mutex);
  for (const std::string& m : g_messages) {
    UNSCOPED_INFO("logged: " << m);
  }
  CHECK(g_messages.empty());
  g_messages.clear();
}

void MujocoWarningGuard::check(const sim::Simulation& sim) {
  INFO("MuJoCo warnings: " << sim.warnings().describe());
  CHECK(sim.warnings().total() == 0);
}

std::vector<std::string> MujocoWarningGuard::take_messages() {
  std::lock_guard<std::mutex> lock(g_mutex);
  std::vector<std::string> out;
  out.swap(g_messages);
  return out;
}

sim::Model load_inline(const std::string& xml) {
  try {
    return sim::Model::from_string(xml, "<inline test model>");
  } catch (const sim::ModelLoadError& e) {
    FAIL("inline MJCF did not compile: " << e.what());
    throw;
  }
}

std::string binary_dir() {
  const char* dir = std::getenv("BIODYN_BINARY_DIR");
  return dir ? dir : BIODYN_DEFAULT_BINARY_DIR;
}

std::string source_dir() {
  const char* dir = std::getenv("BIODYN_SOURCE_DIR");
  return dir ? dir : BIODYN_DEFAULT_SOURCE_DIR;
}

}  // namespace biodyn::testing
