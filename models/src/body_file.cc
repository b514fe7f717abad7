#include "biodyn/models/body_file.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/models/marker_set.h"
#include "biodyn/sim/errors.h"
#include "json_input.h"

namespace biodyn::models {
namespace {

using nlohmann::json;
using sim::InvalidArgument;

json marker_json(const MarkerPlacement& p) {
  json m = {{"name", p.name}, {"part", p.part}};
  if (p.position_B) {
    m["offset_m"] = {p.position_B->x(), p.position_B->y(), p.position_B->z()};
  } else {
    m["along"] = p.along;
    m["ant"] = p.ant;
    m["lat"] = p.lat;
    m["sup"] = p.sup;
  }
  if (!p.description.empty()) m["description"] = p.description;
  return m;
}

bool same(double a, double b) { return std::abs(a - b) <= 1e-6 * std::max(std::abs(a), 1.0); }

/// "" when the optional values agree, else what differs.
std::string compare(const std::string& what, const std::optional<double>& a,
                    const std::optional<double>& b) {
  if (a.has_value() == b.has_value() && (!a || same(*a, *b))) return "";
  const auto text = [](const std::optional<double>& v) {
    return v ? std::to_string(*v) : std::string("(not set)");
  };
  return what + " " + text(a) + " vs " + text(b);
}

}  // namespace

std::string format_body_json(const CharacterSpec& spec, bool compact) {
  json doc = {{"height_m", spec.height_m},
              {"mass_kg", spec.mass_kg},
              {"sex", to_string(spec.sex)},
              {"detail", to_string(spec.detail)}};
  if (!spec.overrides.empty()) {
    json segments = json::object();
    for (const auto& [name, o] : spec.overrides) {
      json s = json::object();
      if (o.mass_kg) s["mass_kg"] = *o.mass_kg;
      if (o.length_m) s["length_m"] = *o.length_m;
      if (o.width_m) s["width_m"] = *o.width_m;
      segments[name] = s;
    }
    doc["segments"] = segments;
  }
  if (!spec.markers.empty()) {
    json markers = json::array();
    for (const MarkerPlacement& p : spec.markers) markers.push_back(marker_json(p));
    doc["markers"] = markers;
  }
  // Names may carry any byte a capture had: replace what is not UTF-8 rather than fail.
  return doc.dump(compact ? -1 : 1, ' ', false, json::error_handler_t::replace) +
         (compact ? "" : "\n");
}

CharacterSpec parse_body_json(const std::string& json_text, const std::string& source) {
  const json doc = parse_json_input(json_text, source);
  if (!doc.is_object()) {
    throw InvalidArgument(source +
                          ": expected a body object {\"height_m\": ..., \"mass_kg\": "
                          "..., \"sex\": ..., \"detail\": ...}, found " +
                          std::string(doc.type_name()));
  }
  for (const auto& [key, value] : doc.items()) {
    if (key != "height_m" && key != "mass_kg" && key != "sex" && key != "detail" &&
        key != "segments" && key != "markers") {
      throw InvalidArgument(source + ": unknown field '" + key +
                            "' (expected height_m, mass_kg, sex, detail, segments, markers)");
    }
  }
  CharacterSpec spec;
  for (const char* key : {"height_m", "mass_kg"}) {
    if (!doc.contains(key) || !doc[key].is_number()) {
      throw InvalidArgument(source + ": " + key + ": expected a number, found " +
                            (doc.contains(key) ? doc[key].dump() : std::string("nothing")));
    }
  }
  spec.height_m = doc["height_m"].get<double>();
  spec.mass_kg = doc["mass_kg"].get<double>();
  for (const char* key : {"sex", "detail"}) {
    if (!doc.contains(key) || !doc[key].is_string()) {
      throw InvalidArgument(source + ": " + key + ": expected a string, found " +
                            (doc.contains(key) ? doc[key].dump() : std::string("nothing")));
    }
  }
  spec.sex = parse_sex(doc["sex"].get<std::string>(), source + ": sex");
  spec.detail = parse_detail(doc["detail"].get<std::string>(), source + ": detail");
  if (doc.contains("segments")) {
    spec.overrides = parse_overrides(json{{"segments", doc["segments"]}}.dump(), source);
    check_override_names(spec.overrides, spec.detail, source);
  }
  if (doc.contains("markers")) {
    spec.markers = parse_marker_set(json{{"markers", doc["markers"]}}.dump(), source).markers;
  }
  spec.validate();
  return spec;
}

std::string geometry_difference(const CharacterSpec& a, const CharacterSpec& b) {
  // Every whole-body difference (a user changing the sex also sees the default height), then
  // the first segment's.
  std::ostringstream out;
  const char* sep = "";
  if (a.sex != b.sex) {
    out << "sex " << to_string(a.sex) << " vs " << to_string(b.sex);
    sep = "; ";
  }
  if (a.detail != b.detail) {
    out << sep << "detail " << to_string(a.detail) << " vs " << to_string(b.detail);
    sep = "; ";
  }
  if (!same(a.height_m, b.height_m)) {
    out << sep << "height " << a.height_m << " m vs " << b.height_m << " m";
  }
  if (!out.str().empty()) return out.str();
  std::map<std::string, std::pair<SegmentOverride, SegmentOverride>> both;
  for (const auto& [name, o] : a.overrides) both[name].first = o;
  for (const auto& [name, o] : b.overrides) both[name].second = o;
  for (const auto& [name, pair] : both) {
    for (const std::string& d :
         {compare("segments." + name + ".length_m", pair.first.length_m, pair.second.length_m),
          compare("segments." + name + ".width_m", pair.first.width_m, pair.second.width_m)}) {
      if (!d.empty()) return d;
    }
  }
  return "";
}

}  // namespace biodyn::models
