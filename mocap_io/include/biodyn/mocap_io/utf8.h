#pragma once
/// Names read from capture files, as UTF-8 (issue 24). C3D labels are bytes (Latin-1 is legal
/// there), TRC and BVH are text in no stated encoding; everything downstream (JSON outputs
/// above all) needs UTF-8. The C3D, TRC and BVH readers pass every name through to_utf8.

#include <string>
#include <string_view>

namespace biodyn::mocap_io {

/// `raw` as UTF-8: every well-formed UTF-8 sequence (RFC 3629: no overlong forms, no
/// surrogates, nothing above U+10FFFF) is kept as it is, so UTF-8 text passes unchanged; every
/// other byte is read as Latin-1 (ISO 8859-1: byte 0xNN is U+00NN) and written as its UTF-8
/// encoding ("M\xE9" becomes "Mé"). Never throws; the result is always valid UTF-8.
std::string to_utf8(std::string_view raw);

/// Whether `text` is well-formed UTF-8 (then to_utf8(text) == text).
bool is_utf8(std::string_view text);

}  // namespace biodyn::mocap_io
