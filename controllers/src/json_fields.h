#pragma once
// Reading JSON fields with errors that name the field, the rule and the value (shared by the
// parameter files of controllers/; internal).

#include <cmath>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "biodyn/sim/errors.h"

namespace biodyn::controllers::json_fields {

inline std::string number_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

/// Throws sim::InvalidArgument "<where>: <rule>, got <got>".
[[noreturn]] inline void fail(const std::string& where, const std::string& rule,
                              const std::string& got) {
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

inline bool boolean(const nlohmann::json& j, const std::string& where) {
  if (!j.is_boolean()) fail(where, "must be true or false", j.dump());
  return j.get<bool>();
}

inline std::vector<double> numbers(const nlohmann::json& j, const std::string& where) {
  if (!j.is_array()) fail(where, "must be an array of numbers", j.dump());
  std::vector<double> out;
  for (std::size_t i = 0; i < j.size(); ++i)
    out.push_back(read_number(j[i], where + "[" + std::to_string(i) + "]"));
  return out;
}

// Reads an object's keys with one handler per key; unknown keys are errors.
inline void read_object(
    const nlohmann::json& j, const std::string& where,
    const std::map<std::string, std::function<void(const nlohmann::json&, const std::string&)>>&
        keys) {
  if (!j.is_object()) fail(where, "must be an object", j.dump());
  for (auto it = j.begin(); it != j.end(); ++it) {
    const auto k = keys.find(it.key());
    if (k == keys.end()) {
      std::string known;
      for (const auto& kv : keys) known += (known.empty() ? "" : ", ") + kv.first;
      fail(where + "." + it.key(), "unknown key (known: " + known + ")", it.value().dump());
    }
    k->second(it.value(), where + "." + it.key());
  }
}

}  // namespace biodyn::controllers::json_fields
