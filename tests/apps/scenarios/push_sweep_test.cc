// The push sweep as a library (scenarios/push_sweep.h): its cells, one cell's run, the summary.
// Any driver (threads today, MPI ranks later) gives the same figures, because a cell is its own
// deterministic run.
#include "biodyn/scenarios/push_sweep.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "biodyn/models/mjcf.h"
#include "biodyn/sim/errors.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;
using scenarios::PushCellResult;
using scenarios::PushOutcome;
using scenarios::PushSweepCell;
using scenarios::PushSweepSpec;

namespace {

PushSweepSpec small_spec() {
  PushSweepSpec spec;
  spec.walk.config.weld = controllers::WeldMode::kOff;
  scenarios::WalkPush push;
  push.settle_strides = 1;
  push.watch_s = 1.0;
  spec.walk.config.walk_push = push;
  spec.walk.duration_s = 30;
  spec.directions = 4;
  spec.durations_s = {0.1, 0.3};
  spec.phases = 3;
  return spec;
}

// One 0.2 s pelvis push of `force_N` during steady walking, honest weld, on `body`, with the
// walker parameters `gait_json` ("" for the defaults); reaction_time_s 0: the default t_r.
PushOutcome honest_push(
    const models::CharacterSpec& body, double force_N, const PushSweepCell& cell,
    const char* gait_json, std::string* failure,
    controllers::WalkerActuation actuation = controllers::WalkerActuation::kTorque,
    double reaction_time_s = 0, double speed_m_s = 1.0) {
  PushSweepSpec spec;
  spec.walk.config.speed_m_s = speed_m_s;
  spec.walk.config.weld = controllers::WeldMode::kHonest;
  spec.walk.config.walker_actuation = actuation;
  spec.walk.config.reaction_time_s = reaction_time_s;
  spec.walk.config.walk_push = scenarios::WalkPush{};
  spec.walk.duration_s = 30;
  spec.fixed_force_N = force_N;
  spec.walk.config.gait_json = gait_json;
  spec.walk.config.gait_source = "test";
  sim::Simulation s(biodyn::testing::generated_character(body));
  const PushCellResult r = scenarios::run_push_cell(&s, spec, cell);
  *failure = r.failure;
  return r.outcome;
}

// A parameter's worth on one push: `cell` survives with the walker JSON `surviving` and fails
// with `failing` by `failing_outcome` (a fall, or the speed not back); "" is the defaults.
void check_survives_where_other_fails(const models::CharacterSpec& body, double force_N,
                                      const PushSweepCell& cell, const char* surviving,
                                      const char* failing, controllers::WalkerActuation actuation,
                                      double reaction_time_s, double speed_m_s,
                                      PushOutcome failing_outcome) {
  const auto name = [](const char* json) { return *json ? json : "defaults"; };
  std::string survivor_failure, other_failure;
  const PushOutcome survivor = honest_push(body, force_N, cell, surviving, &survivor_failure,
                                           actuation, reaction_time_s, speed_m_s);
  const PushOutcome other = honest_push(body, force_N, cell, failing, &other_failure, actuation,
                                        reaction_time_s, speed_m_s);
  INFO(name(surviving) << ": " << (survivor_failure.empty() ? "survived" : survivor_failure) << "; "
                       << name(failing) << ": "
                       << (other_failure.empty() ? "survived" : other_failure));
  CHECK(survivor == PushOutcome::kSurvived);
  CHECK(other == failing_outcome);
}

// The defaults survive `cell` and `before` (walker JSON: the parameter as it was) fails it.
void check_defaults_survive_where_before_fell(
    const models::CharacterSpec& body, double force_N, const PushSweepCell& cell,
    const char* before,
    controllers::WalkerActuation actuation = controllers::WalkerActuation::kTorque,
    double reaction_time_s = 0, double speed_m_s = 1.0,
    PushOutcome before_outcome = PushOutcome::kFell) {
  check_survives_where_other_fails(body, force_N, cell, "", before, actuation, reaction_time_s,
                                   speed_m_s, before_outcome);
}

}  // namespace

TEST_CASE("The sweep's cells: durations, then directions evenly from forward, then onset phases",
          "[scenarios][push]") {
  const PushSweepSpec spec = small_spec();
  REQUIRE_NOTHROW(spec.validate());
  const std::vector<PushSweepCell> cells = scenarios::push_sweep_cells(spec);
  REQUIRE(cells.size() == 2 * 4 * 3);
  CHECK(cells[0].duration_s == 0.1);
  CHECK(cells[0].direction_deg == 0);
  CHECK(cells[0].onset_phase == 0);
  CHECK(cells[1].onset_phase == Approx(1.0 / 3));
  CHECK(cells[3].direction_deg == 90);
  CHECK(cells[11].direction_deg == 270);
  CHECK(cells[12].duration_s == 0.3);
  CHECK(cells.back().onset_phase == Approx(2.0 / 3));
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest, "A bad sweep is refused naming the option",
                 "[scenarios][push]") {
  const auto refused = [](PushSweepSpec spec, const std::string& option) {
    INFO(option);
    CHECK_THROWS_WITH(spec.validate(), Catch::Contains(option));
  };
  PushSweepSpec s = small_spec();
  s.directions = 0;
  refused(s, "--directions");
  s = small_spec();
  s.phases = 101;
  refused(s, "--phases");
  s = small_spec();
  s.durations_s = {0.2, 0};
  refused(s, "--durations");
  s = small_spec();
  s.durations_s.clear();
  refused(s, "--durations");
  s = small_spec();
  s.scan.resolution_N = 0;
  refused(s, "--resolution");
  s = small_spec();
  s.fixed_force_N = -5;
  refused(s, "--fixed-force");
  s = small_spec();
  s.walk.config.walk_push.reset();
  refused(s, "push");
}

TEST_CASE_METHOD(
    biodyn::testing::SimulationTest,
    "The summary: worst and mean over phases per direction and duration, failed walks flagged",
    "[scenarios][push]") {
  PushSweepSpec spec = small_spec();
  spec.durations_s = {0.2};
  spec.directions = 2;
  spec.phases = 2;
  std::vector<PushCellResult> results;
  const double survived[] = {300, 200, 150, 0};
  const std::vector<PushSweepCell> cells = scenarios::push_sweep_cells(spec);
  for (std::size_t i = 0; i < cells.size(); ++i) {
    PushCellResult r;
    r.cell = cells[i];
    r.max_survived_N = survived[i];
    r.bisection_N = survived[i] + 100;
    r.not_pushed = i == 3;
    results.push_back(r);
  }
  std::swap(results[0], results[3]);  // any order: a driver collects them as they finish
  const scenarios::PushSweepSummary sum = scenarios::summarize_push_sweep(spec, results);
  REQUIRE(sum.groups.size() == 2);
  CHECK(sum.groups[0].direction_deg == 0);
  CHECK(sum.groups[0].max_survived_worst_N == 200);
  CHECK(sum.groups[0].max_survived_mean_N == 250);
  CHECK(sum.groups[0].bisection_worst_N == 300);
  CHECK_FALSE(sum.groups[0].walk_failed_before_push);
  CHECK(sum.groups[1].direction_deg == 180);
  CHECK(sum.groups[1].max_survived_worst_N == 0);
  CHECK(sum.groups[1].walk_failed_before_push);
  CHECK(sum.groups_with_failed_walks == 1);

  // Fixed force: the share of pushes survived.
  spec.fixed_force_N = 120;
  for (PushCellResult& r : results)
    r.outcome = r.cell.onset_phase == 0 ? PushOutcome::kSurvived : PushOutcome::kFell;
  const scenarios::PushSweepSummary fixed = scenarios::summarize_push_sweep(spec, results);
  CHECK(fixed.pushes_survived == 2);
  CHECK(fixed.groups[0].survived_phases == 1);
  CHECK(fixed.groups[0].max_survived_worst_N == 0);
  CHECK(fixed.groups[0].max_survived_mean_N == 60);

  // A missing cell is an error, not a NaN.
  results.erase(std::remove_if(results.begin(), results.end(),
                               [](const PushCellResult& r) { return r.cell.direction_deg == 180; }),
                results.end());
  CHECK_THROWS_AS(scenarios::summarize_push_sweep(spec, results), sim::InvalidArgument);
}

TEST_CASE_METHOD(
    testing::SimulationTest,
    "A cell's run is the same on any simulation of the body, whatever ran on it before",
    "[scenarios][push][slow]") {
  PushSweepSpec spec = small_spec();
  spec.scan.resolution_N = 200;
  spec.scan.max_force_N = 400;
  spec.scan.bisect = false;
  const PushSweepCell cell{90, 0.2, 0.5};
  sim::Simulation a = sim::Simulation(biodyn::testing::generated_character()),
                  b = sim::Simulation(biodyn::testing::generated_character());
  const PushCellResult first = scenarios::run_push_cell(&a, spec, cell);
  // b first runs another cell (a hard push that fells the walker), then the same one.
  PushSweepSpec hard = spec;
  hard.fixed_force_N = 1500;
  const PushCellResult felled = scenarios::run_push_cell(&b, hard, PushSweepCell{0, 0.5, 0});
  CHECK(felled.outcome == PushOutcome::kFell);
  CHECK(felled.runs == 1);
  CHECK_FALSE(felled.failure.empty());
  const PushCellResult second = scenarios::run_push_cell(&b, spec, cell);
  INFO(first.failure);
  CHECK_FALSE(first.not_pushed);
  CHECK(first.runs >= 1);
  CHECK(second.max_survived_N == first.max_survived_N);
  CHECK(second.first_failure_N == first.first_failure_N);
  CHECK(second.outcome == first.outcome);
  CHECK(second.runs == first.runs);
  CHECK(first.bisection_N == -1);
  // The scan's figure is on its grid and below its first failure.
  CHECK(std::fmod(first.max_survived_N, 200.0) == 0.0);
  if (first.first_failure_N > 0) CHECK(first.first_failure_N == first.max_survived_N + 200);
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "A hard sideways push is caught over side steps of a bounded roll, not one split",
                 "[scenarios][push]") {
  // 350 N x 0.2 s to the left at the right foot's strike (the left leg swings next), honest weld:
  // unbounded, the balance feedback's side step was 0.84 m wide and its slanted leg gave way at
  // the next strike (controllers/README.md, max_swing_roll_rad). With the sideways catching step
  // (catch_side_deadband_m_s) the unbounded side step comes sooner and survives too: the bound
  // is compared without it.
  const PushSweepCell cell{90, 0.2, 0.5};
  std::string failure;
  const PushOutcome defaults = honest_push({}, 350, cell, "", &failure);
  INFO(failure);
  CHECK(defaults == PushOutcome::kSurvived);
  const PushOutcome bounded =
      honest_push({}, 350, cell, R"({"catch_side_deadband_m_s": 0})", &failure);
  CHECK(bounded == PushOutcome::kSurvived);
  const PushOutcome unbounded = honest_push(
      {}, 350, cell, R"({"catch_side_deadband_m_s": 0, "max_swing_roll_rad": 1.5})", &failure);
  CHECK(unbounded == PushOutcome::kFell);
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "A push from the front at a strike: no step back while the capture point is "
                 "over the feet",
                 "[scenarios][push]") {
  // 1.55 m / 50 kg, 219 N (350 N x 50/80 kg) x 0.2 s from the front at the left strike,
  // honest weld. Ungated, the base-polygon rule stepped back while the body was nearly at rest,
  // the CoM rolled forward onto the other foot and the walker swung that loaded leg: a fall
  // 1.05 s after the onset (controllers/README.md, back_step_capture_point).
  models::CharacterSpec body;
  body.height_m = 1.55;
  body.mass_kg = 50;
  check_defaults_survive_where_before_fell(body, 219, PushSweepCell{180, 0.2, 0.0},
                                           R"({"back_step_capture_point": false})");
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "With stance_hip_load_share the stance hip's roll follows its foot's load",
                 "[scenarios][push]") {
  // 350 N x 0.2 s from behind-left (45 deg) at 0.3 of the stride, 1.80 m / 80 kg, t_r 100 ms.
  // The catching step lands 30 cm beside the CoM; with the whole roll torque on the new stance
  // hip (the default), holding the pelvis level with the CoM far inside its foot while the
  // trailing foot still carries the weight, that foot slides 40 cm outwards and lifts: a fall
  // 1.1 s after the onset. With the option the foot stays down (controllers/README.md,
  // stance_hip_load_share; off by default: it costs 0.1 s pushes from the front). Both without
  // flight_stance_thigh, which saves this push by itself.
  check_survives_where_other_fails(
      {}, 350, PushSweepCell{45, 0.2, 0.3},
      R"({"stance_hip_load_share": true, "flight_stance_thigh": false})",
      R"({"flight_stance_thigh": false})", controllers::WalkerActuation::kTorque, 0.1, 1.0,
      PushOutcome::kFell);
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "In the air the stance hip holds its thigh, not the pelvis", "[scenarios][push]") {
  // 350 N x 0.2 s from behind-right (315 deg) at the left strike, 1.80 m / 80 kg, t_r 100 ms.
  // The body vaults over its straightening stance leg into a flight; with the torso torque on
  // the stance hip in the air (flight_stance_thigh false) it turns the legs instead of the
  // pelvis, they splay and the body falls 1.0 s after the onset. It survives 320-380 N with the
  // default, falls at 350 and 380 N without (controllers/README.md, twentieth session).
  check_defaults_survive_where_before_fell({}, 350, PushSweepCell{315, 0.2, 0.0},
                                           R"({"flight_stance_thigh": false})",
                                           controllers::WalkerActuation::kTorque, 0.1);
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "The velocity-based driver's step back lands with the landing knee",
                 "[scenarios][push]") {
  // 350 N x 0.2 s from the front at 0.4 of the stride, 1.80 m / 80 kg, velocity actuation.
  // With the early swing's knee the rule's step back folds the foot behind the hip and strikes
  // on a bent knee, the next foot lands bent too and the body falls backwards 1.4 s after the
  // onset (controllers/README.md, back_step_landing_knee; the cell was 0.9 of the stride from
  // start_pitch_handover until the velocity driver's start of 3 s, and 0.4 before).
  check_defaults_survive_where_before_fell({}, 350, PushSweepCell{180, 0.2, 0.4},
                                           R"({"back_step_landing_knee": false})",
                                           controllers::WalkerActuation::kVelocity);
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "The velocity-based driver's lateral gain: a push from the right mid-stride",
                 "[scenarios][push]") {
  // 350 N x 0.2 s to the left at 0.4 of the stride, 1.80 m / 80 kg: the velocity defaults'
  // frontal_cv (0.36) recovers; the torque walker's 0.48 over the same gait fell (8 x 10 sweep:
  // 83.8 -> 91.2 %, controllers/README.md). Since the drift integral counts a step's sideways
  // travel only up to lateral_integral_step_limit_m, 0.48 survives this push too; it fell
  // with the push's whole travel counted, as when the gain was chosen, and with the sideways
  // catching step it is "speed not back in 4 strides", not a fall.
  check_defaults_survive_where_before_fell(
      {}, 350, PushSweepCell{90, 0.2, 0.4},
      R"({"frontal_cv": 0.48, "lateral_integral_step_limit_m": 0, "catch_side_deadband_m_s": 0})",
      controllers::WalkerActuation::kVelocity);
}

TEST_CASE_METHOD(
    testing::SimulationTest,
    "A push from behind at t_r 100 ms: an earlier catching step (catch_step_s_per_m_s)",
    "[scenarios][push]") {
  // 350 N x 0.2 s forward at 0.4 of the stride, 1.80 m / 80 kg, muscles' reaction time 100 ms.
  // On the clock the early swing held the knee at 66-73 deg for 0.45 s while the body moved
  // forward at 1.8-1.9 m/s; the foot landed on a knee bent 51 deg (68 deg 0.1 s later) that the
  // rate-limited torque could not hold. The defaults' catching step ends the swing 0.25 s sooner
  // by the forward speed over the walk's own (controllers/README.md), and the body is caught.
  // (The cell was 0.1 of the stride until flight_stance_thigh saved that push without it too.)
  check_defaults_survive_where_before_fell({}, 350, PushSweepCell{0, 0.2, 0.4},
                                           R"({"catch_step_s_per_m_s": 0})",
                                           controllers::WalkerActuation::kTorque, 0.1);
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "A push from the side at t_r 100 ms: the crossover comes sooner "
                 "(catch_side_deadband_m_s)",
                 "[scenarios][push]") {
  // 350 N x 0.2 s to the right at 0.4 of the stride (the right foot's late swing), 1.80 m /
  // 80 kg, t_r 100 ms: the right foot lands before the push is felt, and the left crosses
  // over. On the clock that crossover came 0.48 s later with the capture point 27 cm beyond
  // it, and each side step after fell further behind (fell 1.75 s after the onset). The
  // sideways speed over the deadband ends the swings sooner (controllers/README.md).
  check_defaults_survive_where_before_fell({}, 350, PushSweepCell{270, 0.2, 0.4},
                                           R"({"catch_side_deadband_m_s": 0})",
                                           controllers::WalkerActuation::kTorque, 0.1);
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "A push from the front that nearly stops the body: the speed is back in 4 "
                 "strides (speed_recovery_gain_rad_per_m_s)",
                 "[scenarios][push]") {
  // 350 N x 0.2 s backwards at 0.3 of the stride, 1.80 m / 80 kg, 1.0 m/s, t_r 100 ms: the body
  // then walked on the spot and slowly backwards (-0.1 m/s) for 6 steps while the integral
  // leaned it forward, and its speed was not back within 10 % in 4 strides.
  check_defaults_survive_where_before_fell(
      {}, 350, PushSweepCell{180, 0.2, 0.3}, R"({"speed_recovery_gain_rad_per_m_s": 0})",
      controllers::WalkerActuation::kTorque, 0.1, 1.0, PushOutcome::kSpeedNotRecovered);
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "The velocity-based driver's speed recovery: with its integral at its bound, a "
                 "push from the front is answered from a 0.3 m/s deficit",
                 "[scenarios][push]") {
  // 350 N x 0.2 s backwards at 0.1 of the stride, 1.80 m / 80 kg, 1.0 m/s, t_r 100 ms: the
  // body walks 0.82 m/s with the speed integral at its bound (0.08 rad), so only the recovery
  // term can lean it further; from a 0.6 m/s deficit (the torque walker's) it came too late
  // and the speed was not back within 10 % in 4 strides.
  check_defaults_survive_where_before_fell(
      {}, 350, PushSweepCell{180, 0.2, 0.1}, R"({"speed_recovery_deadband_m_s": 0.6})",
      controllers::WalkerActuation::kVelocity, 0.1, 1.0, PushOutcome::kSpeedNotRecovered);
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "A push at a slow command: the speed integral does not wind up on it "
                 "(speed_integral_step_limit_m_s)",
                 "[scenarios][push]") {
  // 350 N x 0.2 s from behind at 0.2 of the stride, 1.80 m / 80 kg at 0.7 m/s, t_r 20 ms: with
  // the push's steps counted whole, the lean wound down and the stride speed swung about the
  // command for strides; it was not back within 10 % in 4 strides.
  check_defaults_survive_where_before_fell(
      {}, 350, PushSweepCell{0, 0.2, 0.2}, R"({"speed_integral_step_limit_m_s": 0})",
      controllers::WalkerActuation::kTorque, 0.02, 0.7, PushOutcome::kSpeedNotRecovered);
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "The velocity-based driver's sideways catching step: a push to the left at "
                 "t_r 100 ms",
                 "[scenarios][push]") {
  // 350 N x 0.2 s to the left at 0.3 of the stride, 1.80 m / 80 kg, t_r 100 ms: without the
  // sideways catch the body fell 1.8 s after the onset. (The cell was 0.1 of the stride before the
  // start's weight shift, start_shift_s, then 0.2 before the velocity driver's start of 3 s.)
  check_defaults_survive_where_before_fell({}, 350, PushSweepCell{90, 0.2, 0.3},
                                           R"({"catch_side_deadband_m_s": 0})",
                                           controllers::WalkerActuation::kVelocity, 0.1);
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "The velocity-based driver's catching step: a push from behind at t_r 100 ms",
                 "[scenarios][push]") {
  // 350 N x 0.2 s forward at 0.6 of the stride, 1.80 m / 80 kg, t_r 100 ms: without the
  // catching step the body falls (1.6 s after the onset). Its early swing is 0.28 s; a catching
  // step still swings half of it (cut to nothing, the foot came straight back down behind the
  // body and every push from behind at t_r 20 ms fell: controllers/README.md). (The cell was the
  // stride's start before start_pitch_handover, then 0.1 of the stride before the velocity
  // driver's speed bound of 0.08 rad, then 0.5 before its start of 3 s.)
  check_defaults_survive_where_before_fell({}, 350, PushSweepCell{0, 0.2, 0.6},
                                           R"({"catch_step_s_per_m_s": 0})",
                                           controllers::WalkerActuation::kVelocity, 0.1);
}
