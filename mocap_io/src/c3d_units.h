#pragma once
/// Private to mocap_io: the unit strings C3D files use (POINT:UNITS, ANALOG:UNITS) and their SI
/// factors. Spelling is forgiving: case, blanks, '.', '*' and the middle dot are ignored
/// ("Nmm", "N.mm", "N·mm" are one unit).

#include <optional>
#include <string>

namespace biodyn::mocap_io::c3d_internal {

/// m per unit for "mm", "cm", "m"; nullopt for anything else.
std::optional<double> length_unit_m(const std::string& unit);
/// N per unit for "N", "kN"; nullopt for anything else.
std::optional<double> force_unit_N(const std::string& unit);
/// N m per unit for "Nmm", "Ncm", "Nm"; nullopt for anything else.
std::optional<double> moment_unit_Nm(const std::string& unit);

}  // namespace biodyn::mocap_io::c3d_internal
