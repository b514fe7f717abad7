#pragma once
// The scenarios' one error for a value out of range (internal): "<field>: <rule>, got <value>".

#include <sstream>
#include <string>

#include "biodyn/sim/errors.h"

namespace biodyn::scenarios {

[[noreturn]] inline void fail(const std::string& field, const std::string& rule, double value) {
  std::ostringstream s;
  s << field << ": " << rule << ", got " << value;
  throw sim::InvalidArgument(s.str());
}

}  // namespace biodyn::scenarios
