#pragma once
/// Unit conversions, one constant per meaning (style.md habit 4: SI inside, degrees only at the
/// boundaries). Multiply degrees by kRadPerDeg to get radians; divide by kDegPerRad for the same.

namespace biodyn {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kRadPerDeg = kPi / 180.0;  ///< rad per degree
inline constexpr double kDegPerRad = 180.0 / kPi;  ///< degrees per rad

}  // namespace biodyn
