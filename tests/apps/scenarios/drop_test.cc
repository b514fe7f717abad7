#include "biodyn/scenarios/drop.h"
#include "biodyn/models/character.h"
#include "biodyn/models/mjcf.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;

namespace {
// A passive drop only loses energy; MuJoCo's soft contacts and joint limits hold a little as
// "penetration" that this measure does not count and give it back. Measured on the cases
// below: worst 0.92% of the start energy (1.80 m / 80 kg gait: contact storage; 0.28% with a
// 10 ms contact time constant instead of MuJoCo's 20 ms default, which this issue keeps), 0.67%
// for 1.40 m / 150 kg female gait (joint limits: 3.5% before they were stiffened to 5 ms, see
// PhysicsOptions). A real energy leak (bad integration, an unstable light joint) shows as tens
// of percent.
constexpr double kEnergyRiseTolerance = 0.01;  // of the starting mechanical energy
}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Zero-torque drop: no warnings, no NaN, no energy gain, a collapse",
                 "[apps][drop]") {
  struct Case {
    double height, mass;
    models::Sex sex;
    models::Detail detail;
  };
  const Case cases[] = {
      {1.80, 80, models::Sex::kMale, models::Detail::kFull},
      {1.80, 80, models::Sex::kMale, models::Detail::kGait},
      {1.40, 150, models::Sex::kFemale, models::Detail::kGait},
      {1.40, 150, models::Sex::kMale, models::Detail::kGait},
      {2.10, 40, models::Sex::kFemale, models::Detail::kFull},
      {2.10, 150, models::Sex::kMale, models::Detail::kFull},
  };
  for (const Case& k : cases) {
    testing::MujocoWarningGuard per_case;  // a warning fails the test with this case named
    models::CharacterSpec spec{k.height, k.mass, k.sex, k.detail, {}, {}};
    INFO(k.height << " m, " << k.mass << " kg, " << models::to_string(k.sex) << ", "
                  << models::to_string(k.detail));
    sim::Simulation sim(testing::generated_character(spec));
    scenarios::DropParams params;
    params.duration_s = 5.0;
    const scenarios::DropResult r = scenarios::run_drop(&sim, params);
    CHECK(r.finite);
    CHECK(r.warnings.total() == 0);
    CHECK(r.steps == 2500);
    CHECK(r.max_energy_rise_J <= kEnergyRiseTolerance * r.energy_start_J);
    CHECK(r.energy_end_J < 0.5 * r.energy_start_J);  // it fell: potential energy is gone
    CHECK(r.collapse_time_s > 0);
    CHECK(r.com_height_end_m < 0.3 * r.com_height_start_m);
    testing::MujocoWarningGuard::check(sim);
  }
}
