#include "biodyn/sim/log.h"

#include <mujoco/mujoco.h>

#include <cstdlib>
#include <mutex>
#include <string>

namespace biodyn::sim {
namespace {

LogSink& sink_storage() {
  static LogSink sink;
  return sink;
}

void on_mujoco_warning(const char* msg) { log(LogLevel::kWarning, std::string("MuJoCo: ") + msg); }

[[noreturn]] void on_mujoco_error(const char* msg) {
  log(LogLevel::kError, std::string("MuJoCo fatal error: ") + msg);
  std::abort();  // MuJoCo's state is undefined after mju_error; nothing may unwind through C.
}

}  // namespace

LogSink set_log_sink(LogSink sink) {
  LogSink previous = std::move(sink_storage());
  sink_storage() = std::move(sink);
  return previous;
}

void log(LogLevel level, std::string_view message) {
  const LogSink& sink = sink_storage();
  if (sink) sink(level, message);
}

void install_mujoco_handlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    mju_user_warning = &on_mujoco_warning;
    mju_user_error = &on_mujoco_error;
  });
}

const char* to_string(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug:
      return "debug";
    case LogLevel::kInfo:
      return "info";
    case LogLevel::kWarning:
      return "warning";
    case LogLevel::kError:
      return "error";
  }
  return "?";
}

}  // namespace biodyn::sim
