// Names as UTF-8 (issue 24): UTF-8 passes unchanged, every other byte is read as Latin-1, and
// the result is always text a strict JSON writer accepts (cross-checked with nlohmann's).
#include "biodyn/mocap_io/utf8.h"

#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "test_support.h"

using biodyn::mocap_io::is_utf8;
using biodyn::mocap_io::to_utf8;

namespace {

/// Whether nlohmann's strict dump (the one every JSON output used) accepts `s`.
bool strict_json_accepts(const std::string& s) {
  try {
    (void)nlohmann::json(s).dump();
    return true;
  } catch (const nlohmann::json::type_error&) {
    return false;
  }
}

}  // namespace

TEST_CASE("to_utf8 keeps UTF-8 and reads other bytes as Latin-1", "[mocap_io][utf8]") {
  for (const std::string kept :
       {"", "LASI", "Subject:RASI", "H\u00FCfte", "\xE6\x97\xA5\xE6\x9C\xAC", "\xF0\x9F\x98\x80",
        "\xEF\xBF\xBD", "\xF4\x8F\xBF\xBF"}) {
    INFO(kept);
    CHECK(is_utf8(kept));
    CHECK(to_utf8(kept) == kept);
  }
  CHECK(to_utf8("M\xE9") == "M\xC3\xA9");                // é
  CHECK(to_utf8("\xB5V") == "\xC2\xB5V");                // µV
  CHECK(to_utf8("\xFF") == "\xC3\xBF");                  // ÿ
  CHECK(to_utf8("\x80") == "\xC2\x80");                  // a C1 control, still UTF-8
  CHECK(to_utf8("\xC3\xA9\xE9") == "\xC3\xA9\xC3\xA9");  // UTF-8 é kept, Latin-1 é transcoded
  // Not well-formed UTF-8, so each byte is Latin-1: overlong, surrogate, above U+10FFFF, cut.
  CHECK(to_utf8("\xC0\xAF") == "\xC3\x80\xC2\xAF");
  CHECK(to_utf8("\xED\xA0\x80") == "\xC3\xAD\xC2\xA0\xC2\x80");
  CHECK(to_utf8("\xF4\x90\x80\x80") == "\xC3\xB4\xC2\x90\xC2\x80\xC2\x80");
  CHECK(to_utf8("\xE2\x82") == "\xC3\xA2\xC2\x82");
  CHECK_FALSE(is_utf8("M\xE9"));
}

TEST_CASE("to_utf8 of any bytes is text a strict JSON writer accepts", "[mocap_io][utf8]") {
  std::mt19937 rng(24);
  std::uniform_int_distribution<int> byte(0, 255), length(0, 12);
  int not_utf8 = 0;
  for (int trial = 0; trial < 5000; ++trial) {
    std::string raw;
    for (int k = length(rng); k > 0; --k) raw += static_cast<char>(byte(rng));
    INFO("trial " << trial);
    // Two independent validators agree, and the transcoded text passes both.
    CHECK(is_utf8(raw) == strict_json_accepts(raw));
    const std::string text = to_utf8(raw);
    CHECK(is_utf8(text));
    CHECK(strict_json_accepts(text));
    if (is_utf8(raw)) CHECK(text == raw);
    not_utf8 += is_utf8(raw) ? 0 : 1;
  }
  CHECK(not_utf8 > 1000);
}
