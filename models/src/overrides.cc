#include <nlohmann/json.hpp>

#include "biodyn/models/character.h"
#include "biodyn/sim/errors.h"
#include "json_input.h"

namespace biodyn::models {

std::map<std::string, SegmentOverride> parse_overrides(const std::string& json_text,
                                                       const std::string& source) {
  using sim::InvalidArgument;
  const nlohmann::json doc = parse_json_input(json_text, source);
  if (!doc.is_object() || !doc.contains("segments") || !doc["segments"].is_object()) {
    throw InvalidArgument(source + ": expected an object {\"segments\": {name: {...}}}, found " +
                          std::string(doc.type_name()) +
                          (doc.is_object() ? " without an object 'segments'" : ""));
  }
  for (const auto& [key, value] : doc.items()) {
    if (key != "segments") {
      throw InvalidArgument(source + ": unknown top-level field '" + key +
                            "' (expected 'segments')");
    }
  }
  std::map<std::string, SegmentOverride> out;
  for (const auto& [name, fields] : doc["segments"].items()) {
    const std::string where = source + ": segments." + name;
    if (!fields.is_object()) {
      throw InvalidArgument(where +
                            ": expected an object with mass_kg, length_m and/or width_m, found " +
                            std::string(fields.type_name()));
    }
    SegmentOverride o;
    for (const auto& [field, value] : fields.items()) {
      if (field != "mass_kg" && field != "length_m" && field != "width_m") {
        throw InvalidArgument(where + ": unknown field '" + field +
                              "' (expected mass_kg, length_m, width_m)");
      }
      if (!value.is_number()) {
        throw InvalidArgument(where + "." + field + ": expected a number, found " + value.dump());
      }
      const double v = value.get<double>();
      if (!(v > 0)) {
        throw InvalidArgument(where + "." + field + ": must be > 0, got " + value.dump());
      }
      (field == "mass_kg" ? o.mass_kg : field == "length_m" ? o.length_m : o.width_m) = v;
    }
    if (!o.mass_kg && !o.length_m && !o.width_m) {
      throw InvalidArgument(where + ": gives none of mass_kg, length_m, width_m");
    }
    out[name] = o;
  }
  return out;
}

}  // namespace biodyn::models
