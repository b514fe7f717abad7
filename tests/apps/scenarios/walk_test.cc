// The walking scenario (issue 4): read-outs of a walk, one push during walking, bad input.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <sstream>
#include <string>

#include "biodyn/controllers/gait_core.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/scenarios/registry.h"
#include "biodyn/scenarios/stones_sweep.h"
#include "biodyn/scenarios/walk.h"
#include "biodyn/scenarios/walk_scenario.h"
#include "biodyn/scenarios/walk_sweep.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/queries.h"
#include "character.h"
#include "test_support.h"

namespace {

using namespace biodyn;

sim::Simulation make_default_sim() { return sim::Simulation(testing::generated_character()); }

// A walk with a push of 0 N (the protocol's timing and judgement without a disturbance) at
// `onset_phase` after the protocol's 5 settle strides, honest weld.
scenarios::WalkRunParams calm_push_walk(double onset_phase) {
  scenarios::WalkRunParams p;
  p.config.weld = controllers::WeldMode::kHonest;
  scenarios::WalkPush push;
  push.force_N = 0;
  push.onset_phase = onset_phase;
  push.settle_strides = 5;
  p.config.walk_push = push;
  return p;
}

// A velocity-driver walk from standing: by default 8 s at 1.0 m/s, honest weld, flat ground.
struct VelocityWalk {
  double duration_s = 8;
  double reaction_time_s = 0;  // 0: the controller params' own, 20 ms
  double speed_m_s = 1.0;
  controllers::WeldMode weld = controllers::WeldMode::kHonest;
  models::Terrain terrain;
};

// A velocity default's worth: `body` walks `walk` with the defaults (covering more than
// `min_distance_m`, when given) and falls with `before` (walker JSON: the parameter as it was).
void check_defaults_walk_where_before_fell(sim::Simulation* sim, const models::CharacterSpec& body,
                                           const VelocityWalk& walk, const std::string& before,
                                           double min_distance_m = 0) {
  for (const bool defaults : {true, false}) {
    scenarios::WalkRunParams p;
    p.duration_s = walk.duration_s;
    p.config.character = body;
    p.config.terrain = walk.terrain;
    p.config.weld = walk.weld;
    p.config.walker_actuation = controllers::WalkerActuation::kVelocity;
    p.config.reaction_time_s = walk.reaction_time_s;
    p.config.speed_m_s = walk.speed_m_s;
    if (!defaults) {
      p.config.gait_json = before;
      p.config.gait_source = "test";
    }
    const scenarios::WalkRunResult r = scenarios::run_walk(sim, p);
    INFO(body.height_m << " m / " << body.mass_kg << " kg at " << walk.speed_m_s << " m/s, "
                       << (defaults ? "defaults" : before) << ": fell at " << r.time_fallen_s
                       << ", distance " << r.distance_m << ", steady speed " << r.steady_speed_m_s);
    CHECK(r.fallen == !defaults);
    if (defaults && min_distance_m > 0) CHECK(r.distance_m > min_distance_m);
  }
}

}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest, "a walk reports what it measured, consistently",
                 "[apps][walk]") {
  sim::Simulation sim = make_default_sim();
  scenarios::WalkRunParams p;
  p.duration_s = 12;
  p.config.weld = controllers::WeldMode::kHonest;
  std::ostringstream trace;
  p.trace = &trace;
  const scenarios::WalkRunResult r = scenarios::run_walk(&sim, p);
  INFO("fell at " << r.time_fallen_s << ", steady speed " << r.steady_speed_m_s);
  REQUIRE_FALSE(r.fallen);
  CHECK(r.simulated_s == Approx(12).margin(0.003));
  // Honest: no invisible hands.
  CHECK(r.max_root_force_N == 0.0);
  CHECK(r.weld_tension_steps == 0);
  // Strikes: one length, width and time each, in time order.
  REQUIRE(r.steps >= 15);
  CHECK(r.step_lengths_m.size() == static_cast<std::size_t>(r.steps));
  CHECK(r.step_widths_m.size() == static_cast<std::size_t>(r.steps));
  for (std::size_t i = 1; i < r.step_times_s.size(); ++i)
    CHECK(r.step_times_s[i] > r.step_times_s[i - 1]);
  // Cadence from the strike times after the start-up.
  int after = 0;
  double first = -1, last = 0;
  for (double t : r.step_times_s) {
    if (t < scenarios::kWalkStartup_s) continue;
    if (first < 0)
      first = t;
    else
      ++after;
    last = t;
  }
  CHECK(r.cadence_steps_per_min == Approx(after / (last - first) * 60).epsilon(1e-9));
  // Distance and speeds: forward walking, the path a little longer than the straight line.
  CHECK(r.mean_speed_m_s == Approx(r.distance_m / r.simulated_s).epsilon(1e-9));
  CHECK(r.steady_speed_m_s > 0.7);
  CHECK(std::abs(r.lateral_drift_m) < 1.0);
  // Joint ranges: knee flexes in swing, stays straight-ish in stance.
  REQUIRE(r.joint_ranges_deg.count("knee_flexion_l") == 1);
  CHECK(r.joint_ranges_deg.at("knee_flexion_l")[1] > 30);
  CHECK(r.joint_ranges_deg.at("hip_l_flexion")[1] > r.joint_ranges_deg.at("hip_l_flexion")[0] + 20);
  CHECK(r.swing_knee_peak_deg > 30);
  // The swing sole is held level with the toes up: the heel strikes first.
  CHECK(r.heel_strike_fraction > 0.9);
  // Trace: a header and one line per step.
  const std::string t = trace.str();
  CHECK(static_cast<int>(std::count(t.begin(), t.end(), '\n')) == r.sim_steps + 1);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "the walker follows a commanded speed from 0.5 to 1.5 m/s", "[apps][walk]") {
  sim::Simulation sim = make_default_sim();
  for (double v : {0.5, 1.5}) {
    scenarios::WalkRunParams p;
    p.duration_s = 25;
    p.config.speed_m_s = v;
    p.config.weld = controllers::WeldMode::kOff;
    const scenarios::WalkRunResult r = scenarios::run_walk(&sim, p);
    INFO("commanded " << v << " m/s: steady " << r.steady_speed_m_s << ", fell at "
                      << r.time_fallen_s);
    CHECK_FALSE(r.fallen);
    CHECK(std::abs(r.steady_speed_m_s - v) < 0.15 * v);  // the issue's tolerance
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "at a slow command the speed regulation's step term holds every step's speed",
                 "[apps][walk]") {
  // The integral alone swings about 0.5 m/s (steps from 0.22 to 0.78 m/s over ~25 s; the run's
  // mean still within 15%); the proportional step term holds each step near the command.
  sim::Simulation sim = make_default_sim();
  const auto step_speed_rms = [&](const char* gait_json) {
    scenarios::WalkRunParams p;
    p.duration_s = 30;
    p.config.speed_m_s = 0.5;
    p.config.weld = controllers::WeldMode::kOff;
    p.config.gait_json = gait_json;
    const scenarios::WalkRunResult r = scenarios::run_walk(&sim, p);
    INFO("fell at " << r.time_fallen_s);
    REQUIRE_FALSE(r.fallen);
    double sum = 0, previous = 0;
    int n = 0;
    for (std::size_t i = 0; i < r.step_times_s.size(); ++i) {
      const double t = r.step_times_s[i], e = r.step_lengths_m[i] / (t - previous) - 0.5;
      previous = t;
      if (t < scenarios::kWalkStartup_s) continue;
      sum += e * e;
      ++n;
    }
    REQUIRE(n > 20);
    return std::sqrt(sum / n);
  };
  const double with_step_term = step_speed_rms("");
  const double integral_only = step_speed_rms(R"({"speed_step_gain_rad_per_m_s": 0})");
  INFO("step speed RMS about 0.5 m/s: " << with_step_term << " with the step term, "
                                        << integral_only << " without");
  CHECK(with_step_term < 0.07);  // measured 0.027
  CHECK(integral_only > 0.12);   // measured 0.170
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "a push during walking is timed by the gait and judged by the protocol",
                 "[apps][walk][push]") {
  sim::Simulation sim = make_default_sim();
  scenarios::WalkRunParams p = calm_push_walk(0.5);
  const scenarios::WalkRunResult calm = scenarios::run_walk(&sim, p);
  REQUIRE(calm.push);
  INFO(calm.push->failure);
  CHECK(calm.push->survived);
  CHECK(calm.push->recovery_strides == 1);
  CHECK(calm.push->speed_before_m_s > 0.7);
  // Onset: half a stride after the 6th left strike (start stride + 5 settle strides).
  std::vector<double> left;
  for (std::size_t i = 0; i < calm.step_times_s.size(); ++i)
    if (i % 2 == 1) left.push_back(calm.step_times_s[i]);  // the right foot strikes first
  REQUIRE(left.size() > 7);
  CHECK(calm.push->onset_s > left[5]);
  CHECK(calm.push->onset_s < left[6]);
  CHECK(calm.push->end_s == Approx(calm.push->onset_s + 0.2));
  CHECK(calm.push->stride_speeds_after_m_s.size() >= 4);

  // A push no walker takes: 0.5 s of 1500 N forward (delta-v 9 m/s).
  p.config.walk_push->force_N = 1500;
  p.config.walk_push->duration_s = 0.5;
  const scenarios::WalkRunResult hard = scenarios::run_walk(&sim, p);
  REQUIRE(hard.push);
  CHECK_FALSE(hard.push->survived);
  CHECK(hard.push->fell);
  CHECK(hard.push->delta_v_m_s == Approx(1500 * 0.5 / 80).epsilon(1e-6));
  CHECK(hard.fallen);
  CHECK(hard.time_fallen_s > hard.push->onset_s);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "a sideways push does not wind up the drift integral: the walker does not walk "
                 "back across",
                 "[apps][walk][push]") {
  // 1.90 m / 82 kg at 0.51 m/s, 359 N x 0.2 s from 270 deg (350 N per 80 kg), honest weld,
  // t_r 20 ms. Counted whole, the push's ~1 m sideways rolled the feet until the body had
  // walked back across it (0.43, 0.50, 0.34 m/s sideways in strides 3-5), and the stride speed
  // was not back within 10 % in 4 strides. The sideways catching step (catch_side_deadband_m_s)
  // recovers this push with the whole travel counted too, so both runs here are without it.
  models::CharacterSpec body;
  body.height_m = 1.90;
  body.mass_kg = 82;
  sim::Simulation sim(testing::generated_character(body));
  const auto push = [&](const char* gait_json) {
    scenarios::WalkRunParams p = calm_push_walk(0);
    p.config.speed_m_s = 0.51;
    p.config.walk_push->force_N = 359;
    p.config.walk_push->direction_deg = 270;
    p.config.gait_json = gait_json;
    const scenarios::WalkRunResult r = scenarios::run_walk(&sim, p);
    REQUIRE(r.push);
    return *r.push;
  };
  const scenarios::WalkPushOutcome defaults = push("");
  INFO(defaults.failure);
  CHECK(defaults.survived);
  const scenarios::WalkPushOutcome bounded = push(R"({"catch_side_deadband_m_s": 0})");
  INFO(bounded.failure);
  CHECK(bounded.survived);
  const scenarios::WalkPushOutcome whole =
      push(R"({"catch_side_deadband_m_s": 0, "lateral_integral_step_limit_m": 0})");
  CHECK_FALSE(whole.fell);
  CHECK(whole.outcome == scenarios::PushOutcome::kSpeedNotRecovered);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "a push waits for steady strides: the velocity-based driver's slow start",
                 "[apps][walk][push]") {
  // The velocity-based driver needs ~8 s to reach its speed: after 5 strides it is at ~0.8 m/s
  // and still gaining. A push there has no speed to be judged back to (a calm push was judged
  // "speed not back" against the 4 strides before, 0.77 m/s, walking at 0.92 m/s after it).
  sim::Simulation sim = make_default_sim();
  scenarios::WalkRunParams p = calm_push_walk(0);
  p.config.walker_actuation = controllers::WalkerActuation::kVelocity;
  const scenarios::WalkRunResult calm = scenarios::run_walk(&sim, p);
  REQUIRE(calm.push);
  INFO(calm.push->failure << "; speed before " << calm.push->speed_before_m_s << " m/s, onset "
                          << calm.push->onset_s << " s");
  CHECK(calm.push->survived);
  CHECK(calm.push->recovery_strides == 1);
  std::vector<double> left;
  for (std::size_t i = 1; i < calm.step_times_s.size(); i += 2)
    left.push_back(calm.step_times_s[i]);
  REQUIRE(left.size() > 7);
  CHECK(calm.push->onset_s > left[6]);  // later than the 5 settle strides alone
  for (double v : calm.push->stride_speeds_after_m_s)
    CHECK(std::abs(v - calm.push->speed_before_m_s) < 0.05 * calm.push->speed_before_m_s);
  CHECK(calm.push->strides_before >= 6);

  // On a turn (20 deg/s, torque walker) the strides are steady too: their speed is measured
  // along each stride, not over the chord of four (which was 10-18 % short and never steady).
  p.config.walker_actuation = controllers::WalkerActuation::kTorque;
  p.config.heading_rate_deg_s = 20;
  const scenarios::WalkRunResult turning = scenarios::run_walk(&sim, p);
  REQUIRE(turning.push);
  INFO(turning.push->failure);
  CHECK(turning.push->strides_before >= 5);
  CHECK(turning.push->survived);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest, "the walker steps on the paper's stepping stones",
                 "[apps][walk][stones]") {
  sim::Simulation sim = make_default_sim();
  scenarios::WalkRunParams p;
  p.duration_s = 14;
  p.config.scenario = "stones";
  p.config.speed_m_s = 0.7;  // the plan's mean step (0.38 m) at the gait's cadence
  p.config.weld = controllers::WeldMode::kOff;
  p.config.steps_m = {0.60, 0.20, 0.50, 0.16, 0.50, 0.30};  // paper §4.2
  const scenarios::WalkRunResult r = scenarios::run_walk(&sim, p);
  REQUIRE(r.stones);
  const scenarios::SteppingStonesResult& s = *r.stones;
  INFO("fell at " << r.time_fallen_s << ", walked " << s.lengths_m.size() << " stones, RMS "
                  << s.rms_error_m);
  CHECK_FALSE(r.fallen);
  REQUIRE(s.complete);
  CHECK(s.start_s >= p.config.steps_start_s);
  // The walked lengths are the strikes' own, in order, and the errors their differences.
  double sq = 0;
  for (std::size_t i = 0; i < s.lengths_m.size(); ++i) {
    CHECK(s.errors_m[i] == Approx(s.lengths_m[i] - s.targets_m[i]).margin(1e-12));
    sq += s.errors_m[i] * s.errors_m[i];
    const auto k = std::find(r.step_lengths_m.begin(), r.step_lengths_m.end(), s.lengths_m[i]);
    CHECK(k != r.step_lengths_m.end());
  }
  CHECK(s.rms_error_m == Approx(std::sqrt(sq / 6)).margin(1e-12));
  // The issue's bound (measured: 1.3 cm; 1.8 cm before the knee tucked at mid-swing,
  // placed_tuck_m; 2.5 cm before the long first step waited in the air for the hip,
  // placed_wait_s).
  CHECK(s.rms_error_m < 0.02);
  CHECK(s.out_of_reach.empty());
  CHECK(s.across_m.empty());  // lengths only: the balance places the feet across
  CHECK(r.max_root_force_N == 0.0);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "stones in 2D: the swing thigh's roll puts the foot across on its stone",
                 "[apps][walk][stones]") {
  sim::Simulation sim = make_default_sim();
  scenarios::WalkRunParams p;
  p.duration_s = 8;
  p.config.scenario = "stones";
  p.config.speed_m_s = 0.8;
  p.config.weld = controllers::WeldMode::kHonest;
  p.config.steps_m = {0.45, 0.4};
  p.config.steps_lateral_m = {0.04, -0.03};
  const scenarios::WalkRunResult r = scenarios::run_walk(&sim, p);
  REQUIRE(r.stones);
  const scenarios::SteppingStonesResult& s = *r.stones;
  REQUIRE(s.lengths_m.size() >= 1);
  REQUIRE(s.across_m.size() == s.lengths_m.size());
  // The first stone: the hips' spacing w outwards from the stance foot, shifted 4 cm left.
  const models::Rig rig(sim.model());
  CHECK(std::abs(s.target_across_m[0] - 0.04) == Approx(rig.hip_spacing_m()).margin(1e-9));
  INFO("across: planned " << s.target_across_m[0] << ", walked " << s.across_m[0]);
  CHECK(std::abs(s.across_m[0] - s.target_across_m[0]) < 0.015);  // measured 0.4-0.8 cm
  // The error is the distance from the stone in the floor's plane.
  CHECK(s.errors_m[0] ==
        Approx(std::hypot(s.lengths_m[0] - s.targets_m[0], s.across_m[0] - s.target_across_m[0]))
            .margin(1e-12));
  CHECK(s.errors_m[0] < 0.02);
}

TEST_CASE("random stone sequences: the same for a seed, within the spec's ranges, to the mm",
          "[apps][walk][stones]") {
  scenarios::StoneSweepSpec spec;
  const scenarios::StoneSequence a = scenarios::random_stone_sequence(spec, 42);
  const scenarios::StoneSequence b = scenarios::random_stone_sequence(spec, 42);
  CHECK(a.lengths_m == b.lengths_m);
  CHECK(a.lateral_m == b.lateral_m);
  CHECK(a.speed_m_s == b.speed_m_s);
  CHECK(scenarios::random_stone_sequence(spec, 43).lengths_m != a.lengths_m);
  REQUIRE(a.lengths_m.size() == 8);
  REQUIRE(a.lateral_m.size() == 8);
  for (std::size_t k = 0; k < 8; ++k) {
    CHECK(a.lengths_m[k] >= 0.2);
    CHECK(a.lengths_m[k] <= 0.65);
    CHECK(std::abs(a.lateral_m[k]) <= 0.1);
    CHECK(std::abs(a.lengths_m[k] * 1000 - std::round(a.lengths_m[k] * 1000)) < 1e-6);
  }
  CHECK(a.speed_m_s >= 0.5);
  CHECK(a.speed_m_s <= 1.0);
  spec.lateral_m = 0;
  CHECK(scenarios::random_stone_sequence(spec, 42).lateral_m.empty());
  spec.stones = 0;
  CHECK_THROWS_WITH(spec.validate(), Catch::Contains("stones"));
}

TEST_CASE("random sweep bodies: the same for a seed, within the spec's ranges, to the cm",
          "[apps][walk]") {
  scenarios::WalkSweepSpec spec;
  spec.bodies = 30;
  spec.seed = 7;
  const std::vector<scenarios::SweepWalk> a = scenarios::random_sweep_walks(spec);
  REQUIRE(a.size() == 30);
  int women = 0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    const scenarios::SweepWalk& w = a[k];
    CHECK(w.seed == 7 + k);
    CHECK(w.body.height_m >= 1.55);
    CHECK(w.body.height_m <= 1.95);
    CHECK(std::abs(w.body.height_m * 100 - std::round(w.body.height_m * 100)) < 1e-6);
    const double bmi = w.body.mass_kg / (w.body.height_m * w.body.height_m);
    CHECK(bmi >= 19 - 0.1);
    CHECK(bmi <= 30 + 0.1);
    CHECK(w.speed_m_s >= 0.5);
    CHECK(w.speed_m_s <= 1.5);
    women += w.body.sex == models::Sex::kFemale ? 1 : 0;
  }
  CHECK(women > 5);  // either sex (30 fair draws: 5 or fewer women has p < 2e-4)
  CHECK(women < 25);
  // A body is its seed's: the same alone (seed 9 as the first of one) and with a speed list,
  // where every body walks each speed in order.
  spec.seed = 9;
  spec.bodies = 1;
  const scenarios::SweepWalk alone = scenarios::random_sweep_walks(spec).at(0);
  CHECK(alone.body.height_m == a[2].body.height_m);
  CHECK(alone.body.mass_kg == a[2].body.mass_kg);
  CHECK(alone.speed_m_s == a[2].speed_m_s);
  spec.speeds_m_s = {0.5, 1.0, 1.5};
  const std::vector<scenarios::SweepWalk> listed = scenarios::random_sweep_walks(spec);
  REQUIRE(listed.size() == 3);
  for (std::size_t k = 0; k < 3; ++k) {
    CHECK(listed[k].body.height_m == alone.body.height_m);
    CHECK(listed[k].speed_m_s == spec.speeds_m_s[k]);
  }
  spec.bodies = 0;
  CHECK_THROWS_WITH(spec.validate(), Catch::Contains("bodies"));
  spec.bodies = 1;
  spec.speeds_m_s = {2.5};
  CHECK_THROWS_WITH(spec.validate(), Catch::Contains("speed"));
  spec.speeds_m_s.clear();
  spec.bmi_min = 40;
  CHECK_THROWS_WITH(spec.validate(), Catch::Contains("BMI"));
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest, "the walker stops back to standing",
                 "[apps][walk][stop]") {
  sim::Simulation sim = make_default_sim();
  for (const controllers::WeldMode weld :
       {controllers::WeldMode::kOff, controllers::WeldMode::kHonest}) {
    scenarios::WalkRunParams p;
    p.duration_s = 16;
    p.config.stop_at_s = 8;
    p.config.weld = weld;
    const scenarios::WalkRunResult r = scenarios::run_walk(&sim, p);
    INFO("weld " << controllers::to_string(weld) << ": stopped at " << r.stopped_at_s
                 << ", fell at " << r.time_fallen_s << ", CoM " << r.final_com_speed_m_s
                 << " m/s at the end");
    CHECK_FALSE(r.fallen);
    CHECK(r.stopped_at_s > 8.0);
    CHECK(r.stopped_at_s < 13.0);  // measured 10.3 s: braking takes a few steps
    CHECK(r.standing_at_end);
    CHECK(r.final_com_speed_m_s < 0.05);
    // No strike after the feet came side by side.
    CHECK(r.step_times_s.back() <= r.stopped_at_s);
    CHECK(r.max_root_force_N == 0.0);
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "a stop from a slow command waits for a lower speed before the closing step",
                 "[apps][walk]") {
  // 1.90 m / 85 kg woman at 0.5 m/s, stop asked at 8 s, honest weld: with the stop speed tuned
  // from 1.0 m/s the closing step came at 0.29 m/s and she swayed backwards and fell after it.
  models::CharacterSpec body;
  body.height_m = 1.90;
  body.mass_kg = 85;
  body.sex = models::Sex::kFemale;
  sim::Simulation sim(testing::generated_character(body));
  const auto stop = [&](const char* gait_json) {
    scenarios::WalkRunParams p;
    p.duration_s = 16;
    p.config.speed_m_s = 0.5;
    p.config.stop_at_s = 8;
    p.config.weld = controllers::WeldMode::kHonest;
    p.config.gait_json = gait_json;
    return scenarios::run_walk(&sim, p);
  };
  const scenarios::WalkRunResult lowered = stop("");
  INFO("fell at " << lowered.time_fallen_s);
  CHECK_FALSE(lowered.fallen);
  CHECK(lowered.stopped_at_s > 0);
  const scenarios::WalkRunResult tuned_at_1 = stop(R"({"stop_speed_per_m_s": 0})");
  CHECK(tuned_at_1.fallen);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "the catching step answers pushes only: slow walks from standing are the "
                 "same without it",
                 "[apps][walk]") {
  // Short, light women at slow commands, t_r 100 ms: the start's lean carries the CoM to
  // 1.1-1.2 m/s. Against the command, the catching step (catch_step_s_per_m_s) shortened those
  // swings and the 1.58 m woman fell at 4.9 s; against the walk's first free step it still
  // fired at 3.8 s on the 1.55 m / 45 kg woman (a reviewer's case): it waits for 3 free steps.
  // The sideways catching step does act in her start (0.5 m/s sideways at 4.45 s; she walks
  // either way, 9.58 against 9.50 m in 12 s): the traces compared are without it.
  struct Case {
    double height_m, mass_kg, speed_m_s;
  };
  for (const Case& c : {Case{1.58, 56.8, 0.79}, Case{1.55, 45, 0.6}}) {
    models::CharacterSpec body;
    body.height_m = c.height_m;
    body.mass_kg = c.mass_kg;
    body.sex = models::Sex::kFemale;
    sim::Simulation sim(testing::generated_character(body));
    const auto walk = [&](const char* gait_json, std::ostringstream* trace) {
      scenarios::WalkRunParams p;
      p.duration_s = 12;
      p.config.speed_m_s = c.speed_m_s;
      p.config.reaction_time_s = 0.1;
      p.config.weld = controllers::WeldMode::kHonest;
      p.config.gait_json = gait_json;
      p.trace = trace;
      return scenarios::run_walk(&sim, p);
    };
    std::ostringstream defaults, with, without;
    const scenarios::WalkRunResult r = walk("", &defaults);
    INFO(c.height_m << " m, " << c.speed_m_s << " m/s: fell at " << r.time_fallen_s);
    CHECK_FALSE(r.fallen);
    CHECK(r.steps >= 12);
    walk(R"({"catch_side_deadband_m_s": 0})", &with);
    walk(R"({"catch_step_s_per_m_s": 0})", &without);
    CHECK(with.str() == without.str());
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "the velocity-based driver's speed integral is bounded: a short body walks a "
                 "command it cannot reach",
                 "[apps][walk]") {
  // A held-out body (walk-sweep --seed 1000: body 1005) levels off at 0.87 m/s under a 1.0 m/s
  // command at t_r 100 ms. Its speed integral wound the lean up and it fell at 31 s; bounded
  // at 0.1 rad it walks on (and at the velocity defaults' 0.08).
  models::CharacterSpec body;
  body.height_m = 1.58;
  body.mass_kg = 63.5;
  body.sex = models::Sex::kFemale;
  sim::Simulation sim(testing::generated_character(body));
  VelocityWalk walk;
  walk.duration_s = 45;
  walk.reaction_time_s = 0.1;
  check_defaults_walk_where_before_fell(&sim, body, walk, R"({"speed_integral_limit_rad": 0.2})");
  // At 1.5 m/s the feed-forward lean of the command above the reference, 0.05 rad, counts
  // against the bound, so the integral stops at 0.05 (walk-sweep --seed 1000 --speeds 1.5: this
  // body fell at 8.4 s). A bound of 0.15 lets it wind to 0.1 on top, as before.
  walk.duration_s = 16;
  walk.speed_m_s = 1.5;
  check_defaults_walk_where_before_fell(&sim, body, walk, R"({"speed_integral_limit_rad": 0.15})");
  // A heavier short woman (walk-sweep --seed 6000: body 6009) at 1.5 m/s: at the bound of
  // 0.1 rad her step speed runs away forwards, the landing knee bending further every step, and
  // she falls at 9.9 s; at the defaults' 0.08 she walks on.
  models::CharacterSpec heavier = body;
  heavier.height_m = 1.56;
  heavier.mass_kg = 72.9;
  sim::Simulation sim_heavier(testing::generated_character(heavier));
  walk.duration_s = 20;
  check_defaults_walk_where_before_fell(&sim_heavier, heavier, walk,
                                        R"({"speed_integral_limit_rad": 0.1})");
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "the velocity-based driver starts every walk as at the reference speed: tall "
                 "heavy bodies get going at 1.5 and 0.5 m/s at t_r 100 ms",
                 "[apps][walk]") {
  // With the command's lean and phase lengths from the first step (start_at_reference_speed
  // off), a 1.87 m / 103.7 kg woman at 1.5 m/s threw her first steps ahead of the swing leg and
  // fell at 1.1 s, and 1.89 m / 105 kg at 0.5 m/s, his lean taken away, fell at 1.5 s (random
  // bodies of walk-sweep's seeds 1000 and 177).
  struct Start {
    double height_m, mass_kg, speed_m_s;
    models::Sex sex;
  };
  for (const Start& start : {Start{1.87, 103.7, 1.5, models::Sex::kFemale},
                             Start{1.89, 105.0, 0.5, models::Sex::kMale}}) {
    models::CharacterSpec body;
    body.height_m = start.height_m;
    body.mass_kg = start.mass_kg;
    body.sex = start.sex;
    sim::Simulation sim(testing::generated_character(body));
    VelocityWalk walk;
    walk.reaction_time_s = 0.1;
    walk.speed_m_s = start.speed_m_s;
    check_defaults_walk_where_before_fell(&sim, body, walk,
                                          R"({"start_at_reference_speed": false})", 2.0);
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "the velocity-based driver's start lasts 3 s: the heaviest tall body gets going "
                 "at 0.5 m/s at t_r 100 ms",
                 "[apps][walk]") {
  // With the start's 1.934 s (the torque walker's), 1.95 m / 120 kg at 0.5 m/s, weld off, fell
  // backwards at 3.7 s: the start handed the lean over to the slow command before the walk had
  // got going.
  models::CharacterSpec body;
  body.height_m = 1.95;
  body.mass_kg = 120;
  sim::Simulation sim(testing::generated_character(body));
  VelocityWalk walk;
  walk.reaction_time_s = 0.1;
  walk.speed_m_s = 0.5;
  walk.weld = controllers::WeldMode::kOff;
  check_defaults_walk_where_before_fell(&sim, body, walk, R"({"start_time_s": 1.934})", 2.0);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "the velocity-based driver shifts its weight onto the first stance foot before "
                 "it lifts the other: a light body gets going at t_r 100 ms",
                 "[apps][walk]") {
  models::CharacterSpec body;
  body.height_m = 1.55;
  body.mass_kg = 50.5;
  sim::Simulation sim(testing::generated_character(body));
  SECTION("the walk, with and without the shift") {
    // Lifted with the CoM midway between the feet (start_shift_s 0), the first swing let the CoM
    // fall towards the swing side at 0.46 m/s, and the body fell at 1.9 s.
    VelocityWalk walk;
    walk.reaction_time_s = 0.1;
    check_defaults_walk_where_before_fell(&sim, body, walk, R"({"start_shift_s": 0})", 2.0);
  }
  SECTION("the shift: the standing balance drives, both feet down, the CoM moving left") {
    scenarios::ScenarioConfig config;
    config.scenario = "walk";
    config.character = body;
    config.walker_actuation = controllers::WalkerActuation::kVelocity;
    config.reaction_time_s = 0.1;
    const std::unique_ptr<scenarios::Scenario> s = scenarios::make_scenario(&sim, config);
    const double shift_s = s->walk()->walker().params().start_shift_s;
    REQUIRE(shift_s > 0);
    const mjModel& m = sim.model();
    const mjData& d = sim.data();
    const auto right_sole_down = [&] {
      return controllers::foot_touches_floor(m, d, s->rig(), models::kRight);
    };
    s->run_until(0.5 * shift_s);
    CHECK(s->pipeline()->driver() == nullptr);  // the standing controller's balance
    CHECK(right_sole_down());
    // Towards the left foot, the walker's first stance (the capture point's goal).
    const double com_vy = sim::center_of_mass(m, d).velocity_W.y();
    CHECK(com_vy > 0.02);
    const std::unique_ptr<scenarios::ScenarioState> saved = s->new_state();
    s->save(saved.get());
    bool lifted = false;
    while (d.time < 0.4) {
      s->step();
      lifted = lifted || !right_sole_down();
      if (d.time < shift_s - 1e-9) CHECK(right_sole_down());
    }
    CHECK(s->pipeline()->driver() != nullptr);  // the walker
    CHECK(lifted);
    // A restore within the shift repeats it and the handover to the walker.
    const std::vector<double> future(d.qpos, d.qpos + m.nq);
    s->restore(*saved);
    CHECK(s->pipeline()->driver() == nullptr);
    s->run_until(0.4);
    CHECK(std::equal(future.begin(), future.end(), d.qpos));
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "the velocity-based driver hands its start's lean to the speed integral: a small "
                 "body climbs the 5 cm step",
                 "[apps][walk][terrain]") {
  // 1.55 m / 50 kg at 1.0 m/s (t_r 20 ms): without the handover its speed integral had built
  // only enough lean for 0.85 m/s by the step up at 6 m, and it stalled there and fell back.
  models::CharacterSpec body;
  body.height_m = 1.55;
  body.mass_kg = 50;
  models::PhysicsOptions physics;
  physics.terrain.kind = models::Terrain::Kind::kSteps;
  sim::Simulation sim(testing::generated_character(body, physics));
  VelocityWalk walk;
  walk.duration_s = 16;  // past the step down at 9 m; t_r the controller's own, 20 ms
  walk.terrain = physics.terrain;
  check_defaults_walk_where_before_fell(&sim, body, walk, R"({"start_pitch_handover": false})",
                                        10.0);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest, "walk inputs out of range are rejected by name",
                 "[apps][walk]") {
  sim::Simulation sim = make_default_sim();
  scenarios::WalkRunParams p;
  p.config.speed_m_s = 3;
  CHECK_THROWS_WITH(scenarios::run_walk(&sim, p), Catch::Contains("speed") && Catch::Contains("3"));
  p = scenarios::WalkRunParams{};
  p.config.walk_push = scenarios::WalkPush{};
  p.config.walk_push->onset_phase = 1.0;
  CHECK_THROWS_WITH(scenarios::run_walk(&sim, p), Catch::Contains("onset-phase"));
  p = scenarios::WalkRunParams{};
  p.config.gait_json = R"({"hip_kp": 400, "hip_kpp": 900})";
  p.config.gait_source = "my_gait.json";
  CHECK_THROWS_WITH(scenarios::run_walk(&sim, p),
                    Catch::Contains("my_gait.json.hip_kpp") && Catch::Contains("unknown key"));
  p.config.gait_json = R"({"hip_kp": -1})";
  CHECK_THROWS_WITH(scenarios::run_walk(&sim, p),
                    Catch::Contains("hip_kp") && Catch::Contains("-1"));
  p.config.gait_json =
      R"({"states": [{"name": "swing", "end": "strike", "swing_knee_rad": 0.5, "knee": 1}]})";
  CHECK_THROWS_WITH(scenarios::run_walk(&sim, p), Catch::Contains("my_gait.json.states[0].knee") &&
                                                      Catch::Contains("unknown key"));
  p.config.gait_json = R"({"states": [{"name": "swing", "end": "later"}]})";
  CHECK_THROWS_WITH(scenarios::run_walk(&sim, p),
                    Catch::Contains("states[0].end") && Catch::Contains("later"));
  p.config.gait_json = "{";
  CHECK_THROWS_WITH(scenarios::run_walk(&sim, p),
                    Catch::Contains("my_gait.json") && Catch::Contains("not valid JSON"));
  p.config.gait_json = R"({"hip_kp": 1e400})";  // beyond a double: bad input, not a bug
  CHECK_THROWS_AS(scenarios::run_walk(&sim, p), sim::InvalidArgument);
  CHECK_THROWS_WITH(scenarios::run_walk(&sim, p),
                    Catch::Contains("my_gait.json") && Catch::Contains("1e400"));
  p = scenarios::WalkRunParams{};
  p.config.scenario = "stones";
  p.config.steps_m = {0.5, 2.0};
  CHECK_THROWS_WITH(scenarios::run_walk(&sim, p),
                    Catch::Contains("planned step 2") && Catch::Contains("2"));
  p.config.steps_m = {0.5};
  p.config.steps_start_s = 30;
  CHECK_THROWS_WITH(scenarios::run_walk(&sim, p),
                    Catch::Contains("steps start") && Catch::Contains("30"));
  p = scenarios::WalkRunParams{};
  p.config.stop_at_s = 25;
  CHECK_THROWS_WITH(scenarios::run_walk(&sim, p),
                    Catch::Contains("stop-at") && Catch::Contains("25"));
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "the velocity-based controllers walk: honest weld and none, t_r 20 and 100 ms",
                 "[apps][walk]") {
  // The paper's controllers (§3) under the walker's gait (WalkerActuation::kVelocity, its own
  // defaults). The defaults before fell at t_r = 100 ms after 8-10 s at 1.5 m/s and 23-27 s at
  // 1.0 m/s (controllers/README.md): 30 s here.
  struct Case {
    controllers::WeldMode weld;
    double reaction_time_s, speed_m_s;
  };
  for (const Case& c : {Case{controllers::WeldMode::kHonest, 0.02, 1.0},
                        Case{controllers::WeldMode::kOff, 0.02, 1.5},
                        Case{controllers::WeldMode::kHonest, 0.1, 0.5},
                        Case{controllers::WeldMode::kHonest, 0.1, 1.0},
                        Case{controllers::WeldMode::kOff, 0.1, 1.5}}) {
    sim::Simulation sim = make_default_sim();
    scenarios::WalkRunParams p;
    p.duration_s = 30;
    p.config.weld = c.weld;
    p.config.walker_actuation = controllers::WalkerActuation::kVelocity;
    p.config.reaction_time_s = c.reaction_time_s;
    p.config.speed_m_s = c.speed_m_s;
    const scenarios::WalkRunResult r = scenarios::run_walk(&sim, p);
    INFO("t_r " << c.reaction_time_s << ", " << c.speed_m_s << " m/s: fell at " << r.time_fallen_s
                << ", steady speed " << r.steady_speed_m_s);
    CHECK_FALSE(r.fallen);
    CHECK(r.max_root_force_N == 0.0);
    CHECK(r.weld_tension_steps == 0);
    CHECK(r.steps >= 30);
    CHECK(r.steady_speed_m_s > 0.4);
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "the paper's lower-body model walks under both controllers, its trunk held",
                 "[apps][walk]") {
  // --detail gait: the upper body is one segment on the pelvis by a 'trunk' joint (the full
  // body's 'lumbar'). The torque walker refused it before; without the trunk's reaction at the
  // stance hip it ran away (1.72 m/s at a 1.0 m/s command) and fell at 8 s.
  sim::Simulation sim(testing::generated_character(models::Detail::kGait));
  for (const controllers::WalkerActuation a :
       {controllers::WalkerActuation::kTorque, controllers::WalkerActuation::kVelocity}) {
    scenarios::WalkRunParams p;
    p.duration_s = 20;
    p.config.walker_actuation = a;
    p.config.weld = controllers::WeldMode::kHonest;
    const scenarios::WalkRunResult r = scenarios::run_walk(&sim, p);
    INFO(controllers::to_string(a)
         << ": steady " << r.steady_speed_m_s << " m/s, fell at " << r.time_fallen_s);
    CHECK_FALSE(r.fallen);
    CHECK(std::abs(r.steady_speed_m_s - 1.0) < 0.15);  // measured 1.02 (torque), 0.98 (velocity)
    // The trunk held within 10 deg of its standing pose, both DOFs (measured within 4 deg with
    // torque actuation, 0.2 deg with velocity actuation).
    for (const char* dof : {"trunk_flexion", "trunk_bending"}) {
      INFO(dof);
      REQUIRE(r.joint_ranges_deg.count(dof) == 1);
      CHECK(r.joint_ranges_deg.at(dof)[0] > -10);
      CHECK(r.joint_ranges_deg.at(dof)[1] < 10);
    }
  }
}
