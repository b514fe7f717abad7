#pragma once
/// Private to models: the JSON input files (overrides, marker sets, body files) parsed one way.

#include <nlohmann/json.hpp>
#include <string>

#include "biodyn/sim/errors.h"

namespace biodyn::models {

/// `text` parsed; throws sim::InvalidArgument "<source>: malformed JSON at byte N: ..." (N is
/// nlohmann's 1-based offset of the error).
inline nlohmann::json parse_json_input(const std::string& text, const std::string& source) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw sim::InvalidArgument(source + ": malformed JSON at byte " + std::to_string(e.byte) +
                               ": " + e.what());
  } catch (const nlohmann::json::exception& e) {  // out_of_range: a number like 1e400
    throw sim::InvalidArgument(source + ": malformed JSON: " + e.what());
  }
}

}  // namespace biodyn::models
