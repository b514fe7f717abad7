#include "c3d_units.h"

#include <cctype>

namespace biodyn::mocap_io::c3d_internal {
namespace {

/// Lower case, without blanks, '.', '*' or the UTF-8 middle dot (0xC2 0xB7).
std::string normalized(const std::string& unit) {
  std::string out;
  for (std::size_t i = 0; i < unit.size(); ++i) {
    const auto c = static_cast<unsigned char>(unit[i]);
    if (c == 0xC2 && i + 1 < unit.size() && static_cast<unsigned char>(unit[i + 1]) == 0xB7) {
      ++i;
      continue;
    }
    if (c == ' ' || c == '.' || c == '*' || c == '\0') continue;
    out.push_back(static_cast<char>(std::tolower(c)));
  }
  return out;
}

}  // namespace

std::optional<double> length_unit_m(const std::string& unit) {
  const std::string u = normalized(unit);
  if (u == "mm") return 1e-3;
  if (u == "cm") return 1e-2;
  if (u == "m") return 1.0;
  return std::nullopt;
}

std::optional<double> force_unit_N(const std::string& unit) {
  const std::string u = normalized(unit);
  if (u == "n") return 1.0;
  if (u == "kn") return 1e3;
  return std::nullopt;
}

std::optional<double> moment_unit_Nm(const std::string& unit) {
  const std::string u = normalized(unit);
  if (u == "nmm") return 1e-3;
  if (u == "ncm") return 1e-2;
  if (u == "nm") return 1.0;
  return std::nullopt;
}

}  // namespace biodyn::mocap_io::c3d_internal
