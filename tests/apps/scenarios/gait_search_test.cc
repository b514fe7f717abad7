// The walker search's push cases (gait_search.h, `biodyn walk-search --pushes`): where they push,
// that push-sweep's own table stays unseen by them, and that a candidate is judged by what the
// push did to its walk; the pushes shared among seeded random bodies; the first generation's
// spread refused outside (0, 0.5].
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <map>
#include <set>

#include "biodyn/controllers/torque_walker.h"
#include "biodyn/scenarios/gait_search.h"
#include "biodyn/scenarios/walk_sweep.h"
#include "biodyn/sim/errors.h"

using namespace biodyn;

namespace {

scenarios::GaitSearchParams velocity_search() {
  const controllers::WalkerActuation velocity = controllers::WalkerActuation::kVelocity;
  return scenarios::default_gait_search(
      controllers::torque_walker_json(controllers::walker_defaults(velocity)), velocity);
}

}  // namespace

TEST_CASE("the search's push cases: 8 directions, phases push-sweep does not use",
          "[scenarios][search]") {
  scenarios::GaitSearchParams p = velocity_search();
  const std::size_t walks = p.cases.size(), dimensions = p.dimensions.size();
  scenarios::add_push_cases(&p, 16);
  REQUIRE(p.cases.size() == walks + 16);
  CHECK(p.dimensions.size() > dimensions);  // the balance gains join the search
  std::set<double> directions;
  for (std::size_t k = walks; k < p.cases.size(); ++k) {
    const scenarios::SearchCase& c = p.cases[k];
    CHECK(c.push_force_N == 350);
    CHECK(c.push_duration_s == 0.2);
    CHECK(c.reaction_time_s == 0.1);
    CHECK_FALSE(c.gait);
    directions.insert(c.push_direction_deg);
    // push-sweep --phases 10 pushes at k / 10 of the stride: none of those.
    const double tenths = c.push_phase * 10;
    INFO("phase " << c.push_phase);
    CHECK(std::abs(tenths - std::round(tenths)) > 0.1);
  }
  CHECK(directions.size() == 8);
  p.validate();
  for (double spread : {0.0, 0.7}) {
    scenarios::GaitSearchParams bad = p;
    bad.initial_spread = spread;
    CHECK_THROWS_WITH(bad.validate(), Catch::Contains("spread"));
  }

  scenarios::GaitSearchParams q = velocity_search();
  scenarios::add_push_cases(&q, 0);
  CHECK(q.cases.size() == walks);
  CHECK(q.dimensions.size() == dimensions);
  for (int bad : {-8, 12, 88}) {
    INFO(bad);
    CHECK_THROWS_WITH(scenarios::add_push_cases(&q, bad),
                      Catch::Contains("pushes") && Catch::Contains(std::to_string(bad)));
  }
}

TEST_CASE("the search's pushes shared among bodies: 1.80 m / 80 kg and walk-sweep's random ones",
          "[scenarios][search]") {
  scenarios::GaitSearchParams p = velocity_search();
  const std::size_t walks = p.cases.size();
  scenarios::add_push_cases(&p, 24, 3, 4242);
  REQUIRE(p.cases.size() == walks + 24);
  scenarios::WalkSweepSpec drawn;
  drawn.bodies = 2;
  drawn.seed = 4242;
  drawn.speeds_m_s = {1.0};
  const std::vector<scenarios::SweepWalk> random = scenarios::random_sweep_walks(drawn);
  // Each body: which directions it is pushed from.
  std::map<std::pair<double, double>, std::set<double>> directions;
  for (std::size_t k = walks; k < p.cases.size(); ++k) {
    const scenarios::SearchCase& c = p.cases[k];
    directions[{c.height_m, c.mass_kg}].insert(c.push_direction_deg);
    const bool named = c.height_m == 1.80 && c.mass_kg == 80;
    const bool drawn_body = std::any_of(random.begin(), random.end(), [&c](const auto& w) {
      return w.body.height_m == c.height_m && w.body.mass_kg == c.mass_kg && w.body.sex == c.sex;
    });
    CHECK((named || drawn_body));
  }
  REQUIRE(directions.size() == 3);
  for (const auto& [body, from] : directions) {
    INFO(body.first << " m " << body.second << " kg");
    CHECK(from.size() == 8);  // 3 pushes per direction, each to another body
  }
  for (int bad : {0, 17}) {
    INFO(bad);
    scenarios::GaitSearchParams q = velocity_search();
    CHECK_THROWS_WITH(scenarios::add_push_cases(&q, 8, bad),
                      Catch::Contains("push bodies") && Catch::Contains(std::to_string(bad)));
  }
}

TEST_CASE("a push case costs what the push did: the same push lost at t_r 100 ms, survived at 20",
          "[scenarios][search][slow]") {
  scenarios::GaitSearchParams p = velocity_search();
  scenarios::SearchCase push;
  push.gait = false;
  push.push_force_N = 350;
  push.push_direction_deg = 0;  // from behind, at 0.3 of the stride (push-sweep's own cell)
  push.push_phase = 0.3;
  push.reaction_time_s = 0.1;
  scenarios::SearchCase quick = push;
  quick.reaction_time_s = 0.02;
  p.cases = {push, quick};
  const scenarios::CandidateResult r = scenarios::evaluate_candidate(p, p.base_json, {});
  REQUIRE(r.cases.size() == 2);
  INFO(r.cases[0].push_failure);
  CHECK(r.cases[0].cost > 0);
  CHECK_FALSE(r.cases[0].push_failure.empty());
  CHECK(r.cases[1].cost == 0);
  CHECK(r.cases[1].push_failure.empty());
  CHECK(r.cost == r.cases[0].cost);
}
