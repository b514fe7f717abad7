#pragma once
/// The library's logger: a single replaceable sink. The library never prints; an app installs
/// a sink (e.g. to stderr) and MuJoCo's error/warning callbacks are routed here.

#include <functional>
#include <string_view>

namespace biodyn::sim {

enum class LogLevel { kDebug, kInfo, kWarning, kError };

/// Receives every message the library (and MuJoCo through it) emits.
using LogSink = std::function<void(LogLevel, std::string_view)>;

/// Installs `sink` (an empty function discards messages) and returns the previous one.
/// Not thread-safe with concurrent logging: install sinks at start-up.
LogSink set_log_sink(LogSink sink);

/// Sends a message to the current sink.
void log(LogLevel level, std::string_view message);

/// Routes MuJoCo's mju_user_warning / mju_user_error to the sink. Called by every sim entry
/// point that loads or steps a model; idempotent.
///
/// MuJoCo's warnings are informational: they are also counted per mjData (see
/// Simulation::warnings()). A MuJoCo *error* is a broken invariant inside the engine (e.g. an
/// exhausted stack); as no exception may cross MuJoCo's C code, the handler logs it and then
/// aborts the process.
void install_mujoco_handlers();

const char* to_string(LogLevel level);

}  // namespace biodyn::sim
