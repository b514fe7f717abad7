#pragma once
/// Helpers every biodyn test uses: a guard that fails the test on any MuJoCo warning, inline
/// MJCF loading, named tolerances.

#include <catch2/catch.hpp>
#include <cstring>
#include <string>
#include <vector>

#include "biodyn/sim/log.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/simulation.h"

namespace biodyn::testing {

/// While alive, captures every warning/error the library logs (MuJoCo's included). On
/// destruction it CHECKs that none was logged, so any MuJoCo warning fails the test.
/// Use check(sim) as well: MuJoCo logs only a warning's first occurrence, the counters see all.
class MujocoWarningGuard {
 public:
  MujocoWarningGuard();
  ~MujocoWarningGuard();
  MujocoWarningGuard(const MujocoWarningGuard&) = delete;
  MujocoWarningGuard& operator=(const MujocoWarningGuard&) = delete;

  /// CHECKs that `sim` counted no MuJoCo warning.
  static void check(const sim::Simulation& sim);
  /// Messages captured so far (and clears them: for tests that expect a warning).
  std::vector<std::string> take_messages();

 private:
  sim::LogSink previous_;
};

/// The fixture of every test that simulates in-process: any MuJoCo warning or error logged while
/// the test runs fails it (TEST_CASE_METHOD(biodyn::testing::SimulationTest, ...)); `guard`
/// takes the messages a test expects (take_messages).
struct SimulationTest {
  MujocoWarningGuard guard;
};

/// Compiles inline MJCF, failing the test with MuJoCo's message if it does not compile.
sim::Model load_inline(const std::string& xml);

/// The biodyn build directory (for running the CLI from tests): $BIODYN_BINARY_DIR, else the
/// build directory this test was compiled in.
std::string binary_dir();
/// The biodyn source directory: $BIODYN_SOURCE_DIR, else the one this test was compiled from.
std::string source_dir();

/// Whether two state vectors are the same bits (a restored or replayed run must be).
inline bool bit_identical(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

}  // namespace biodyn::testing
