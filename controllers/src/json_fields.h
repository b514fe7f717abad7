#pragma once
// Reading JSON fields with errors that name the field, the rule and the value (shared by the
// parameter files of controllers/; internal).

#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "biodyn/sim/errors.h"

namespace biodyn::controllers::json_fields {

inline std::string number_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

/// Throws sim::InvalidArgument "<where>: <rule>, got <got>".
[[noreturn]] inline void fail(const std::string& where, const std::string& rule, const std::string& got) {
  throw sim::InvalidArgument(where + ": " + rule + ", got " + got);
}

/// fail(where, rule, value) unless `ok`.
inline void check(bool ok, const std::string& where, const std::string& rule, double value) {
  if (!ok) fail(where, rule, number_text(value));
}

/// A finite number, or a clear error.
inline double read_number(const nlohmann::json& j, const std::string& where) {
  if (!j.is_number()) fail(where, "must be a number", j.dump());
  const double v = j.get<double>();
  if (!std::isfinite(v)) fail(where, "must be finite", j.dump());
  return v;
}

}  // namespace biodyn::controllers::json_fields
