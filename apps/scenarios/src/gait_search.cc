#include "biodyn/scenarios/gait_search.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <nlohmann/json.hpp>
#include <numeric>
#include <random>
#include <thread>

#include "biodyn/controllers/torque_walker.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/motion_recorder.h"
#include "biodyn/scenarios/push_sweep.h"
#include "biodyn/scenarios/walk.h"
#include "biodyn/scenarios/walk_sweep.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"

namespace biodyn::scenarios {
namespace {

using nlohmann::json;

/// Cost of a fall: the whole run lost, less the share of it walked (a candidate that walks
/// longer is nearer).
constexpr double kFallCost = 1000;
/// Cost of a push not survived (a walk's fall costs 1000-2000: a push lost is less than a walk
/// lost, more than every gait figure's miss).
constexpr double kPushFailCost = 300;
/// A walk's mean speed may miss the command by this fraction before it costs.
constexpr double kSpeedTolerance = 0.10;
/// deg: a mean curve this far (RMS) from the normative one costs 1 (then squared).
constexpr double kCurveScale_deg = 10;
/// Frames per second of the recorded motion the gait figures come from.
constexpr double kRecordHz = 100;
/// How far outside its band a figure costs 1 (then squared), by unit.
double figure_scale(const std::string& unit) {
  if (unit == "r") return 0.05;
  if (unit == "m") return 0.01;
  return 5;  // deg, % cycle, steps/min
}

/// Box–Muller on the 64-bit Mersenne twister: the same draws on every standard library.
class Normal {
 public:
  explicit Normal(unsigned long long seed) : rng_(seed) {}
  double operator()() {
    const double u1 = (static_cast<double>(rng_() >> 11) + 0.5) / 9007199254740992.0;
    const double u2 = (static_cast<double>(rng_() >> 11) + 0.5) / 9007199254740992.0;
    return std::sqrt(-2 * std::log(u1)) * std::cos(2 * M_PI * u2);
  }

 private:
  std::mt19937_64 rng_;
};

WalkRunParams case_run(const GaitSearchParams& p, const SearchCase& c,
                       const std::string& walker_json) {
  WalkRunParams run;
  run.config.scenario = "walk";
  run.config.character.height_m = c.height_m;
  run.config.character.mass_kg = c.mass_kg;
  run.config.character.sex = c.sex;
  run.config.speed_m_s = c.speed_m_s;
  run.config.gait_json = walker_json;
  run.config.walker_actuation = p.actuation;
  run.config.reaction_time_s = c.reaction_time_s;
  run.config.gait_source = "search candidate";
  run.duration_s = p.duration_s;
  return run;
}

/// A simulation of the body `run` walks.
sim::Simulation case_simulation(const WalkRunParams& run) {
  return sim::Simulation(sim::Model::from_string(
      models::to_mjcf(models::generate_character(run.config.model_spec())), "<character>"));
}

CaseOutcome push_case(const GaitSearchParams& p, const SearchCase& c,
                      const std::string& walker_json) {
  PushSweepSpec spec;
  spec.walk = case_run(p, c, walker_json);
  spec.walk.config.walk_push = WalkPush{};
  spec.directions = 1;
  spec.durations_s = {c.push_duration_s};
  spec.phases = 1;
  spec.fixed_force_N = c.push_force_N;
  sim::Simulation sim = case_simulation(spec.walk);
  const PushCellResult r =
      run_push_cell(&sim, spec, {c.push_direction_deg, c.push_duration_s, c.push_phase});
  CaseOutcome out;
  if (r.not_pushed) {
    // The walk fell (or never settled) before the push: as bad as a walk's fall at its start.
    out.fell = true;
    out.cost = 2 * kFallCost;
  } else if (r.outcome != PushOutcome::kSurvived) {
    out.fell = r.outcome == PushOutcome::kFell;
    out.cost = kPushFailCost;
  }
  out.push_failure = r.failure;
  return out;
}

CaseOutcome walk_case(const GaitSearchParams& p, const SearchCase& c,
                      const std::string& walker_json) {
  if (c.push_force_N > 0) return push_case(p, c, walker_json);
  WalkRunParams run = case_run(p, c, walker_json);
  sim::Simulation sim = case_simulation(run);
  const double dt = sim.model().opt.timestep;
  MotionRecorder recorder(sim.model(),
                          std::max(1, static_cast<int>(std::lround(1 / (kRecordHz * dt)))),
                          std::lround(p.duration_s / dt) + 1);
  run.observers.push_back(&recorder);
  const WalkRunResult r = run_walk(&sim, run);
  CaseOutcome out;
  out.fell = r.fallen;
  out.time_fallen_s = r.time_fallen_s;
  out.speed_m_s = r.steady_speed_m_s;
  if (r.fallen) {
    out.cost = kFallCost * (2 - std::clamp(r.time_fallen_s / p.duration_s, 0.0, 1.0));
    return out;
  }
  const double speed_error = std::abs(r.steady_speed_m_s - c.speed_m_s) / c.speed_m_s;
  out.cost += std::pow(std::max(0.0, speed_error - kSpeedTolerance) / 0.05, 2);
  if (!c.gait) return out;
  const RecordedMotion rec = recorder.motion();
  try {
    const GaitAnalysis g = analyse_gait(gait_input(sim.model(), rec, p.analyse_from_s));
    out.figures = g.figures;
    // The mean curves' distance from the normative ones: 1 per 10 deg RMS (squared), so that
    // among gaits inside the bands the one closer to the curves wins.
    for (double rms : g.rms_from_normative_deg) out.cost += std::pow(rms / kCurveScale_deg, 2);
    for (const GaitFigure& f : g.figures) {
      if (!std::isfinite(f.value)) {
        out.cost += 25;
        continue;
      }
      const double outside = std::max({0.0, f.lo - f.value, f.value - f.hi});
      out.cost += std::pow(outside / figure_scale(f.unit), 2);
    }
  } catch (const sim::InvalidArgument&) {
    out.cost += kFallCost;  // walked, but no gait cycle to judge (shuffled or stood)
  }
  return out;
}

}  // namespace

void GaitSearchParams::validate() const {
  auto fail = [](const std::string& what) { throw sim::InvalidArgument("gait search: " + what); };
  if (dimensions.empty()) fail("no dimensions to search");
  for (const SearchDimension& d : dimensions) {
    if (!(d.lo < d.hi))
      fail(d.pointer + ": expected lo < hi, got " + std::to_string(d.lo) + " .. " +
           std::to_string(d.hi));
  }
  if (cases.empty()) fail("no walks to judge a candidate by");
  if (population < 4) fail("population: expected >= 4, got " + std::to_string(population));
  if (generations < 1) fail("generations: expected >= 1, got " + std::to_string(generations));
  if (!(elite_fraction > 0 && elite_fraction <= 0.5))
    fail("elite fraction: expected (0, 0.5], got " + std::to_string(elite_fraction));
  if (!(duration_s > analyse_from_s + 3))
    fail("duration: expected > analyse_from + 3 s (a few cycles), got " +
         std::to_string(duration_s));
  if (threads < 1) fail("threads: expected >= 1, got " + std::to_string(threads));
  if (!(initial_spread > 0 && initial_spread <= 0.5))
    fail("spread: expected (0, 0.5], got " + std::to_string(initial_spread));
  // Every pointer must name a number of the base parameters, and the base must be valid.
  const json base = json::parse(base_json);
  for (const SearchDimension& d : dimensions) {
    const json::json_pointer ptr(d.pointer);
    if (!base.contains(ptr) || !base.at(ptr).is_number())
      fail(d.pointer + ": not a number in the walker's parameters");
  }
  controllers::TorqueWalkerParams check;
  controllers::apply_torque_walker_json(base_json, "the search's base parameters", &check);
}

std::string candidate_json(const std::string& base_json,
                           const std::vector<SearchDimension>& dimensions,
                           const std::vector<double>& x) {
  json j = json::parse(base_json);
  for (std::size_t i = 0; i < dimensions.size(); ++i)
    j[json::json_pointer(dimensions[i].pointer)] = x[i];
  return j.dump(1);
}

GaitSearchParams default_gait_search(const std::string& base_json,
                                     controllers::WalkerActuation actuation) {
  GaitSearchParams p;
  p.actuation = actuation;
  json base = json::parse(base_json);
  // A double support first: the trailing foot pushes off (its ankle plantarflexes) while the
  // leading leg takes the load (human stance ~60 % needs ~10 % double support per step).
  json& states = base["states"];
  if (states.size() == 2) {
    json ds = states[0];
    ds["name"] = "double support";
    ds["end"] = "time";
    ds["duration_s"] = 0.08;
    ds["duration_per_m_s"] = 0.0;
    ds["swing_hip_rad"] = 0.0;
    ds["swing_knee_rad"] = 0.3;
    ds["swing_ankle_rad"] = -0.2;
    ds["swing_foot_down"] = true;
    states.insert(states.begin(), ds);
  }
  p.base_json = base.dump(1);
  p.dimensions = {
      {"/states/0/duration_s", 0.04, 0.16},
      {"/states/0/swing_knee_rad", 0.0, 0.9},
      {"/states/0/swing_ankle_rad", -0.5, 0.1},
      {"/states/0/stance_knee_rad", 0.0, 0.5},
      {"/states/0/stance_ankle_rad", -0.2, 0.2},
      {"/states/1/duration_s", 0.15, 0.5},
      {"/states/1/swing_hip_rad", 0.2, 0.9},
      {"/states/1/swing_knee_rad", 0.6, 1.4},
      {"/states/1/stance_knee_rad", -0.05, 0.35},
      {"/states/1/stance_ankle_rad", -0.2, 0.2},
      {"/states/2/swing_hip_rad", -0.1, 0.5},
      {"/states/2/swing_knee_rad", 0.0, 0.5},
      {"/states/2/stance_knee_rad", -0.05, 0.35},
      {"/states/2/stance_ankle_rad", -0.4, 0.2},
      {"/knee_kp", 150, 700},
      {"/ankle_kp", 30, 400},
      {"/stance_knee_kp", 150, 1200},
      {"/stance_ankle_kp", 30, 1000},
      {"/stance_weight_support", 0.0, 1.0},
      {"/hip_kp", 250, 800},
      {"/pelvis_pitch_rad", -0.05, 0.2},
      {"/sagittal_cd", 0.0, 0.6},
      {"/sagittal_cv", 0.0, 0.5},
      {"/toe_up_rad", 0.0, 0.3},
  };
  const models::Sex man = models::Sex::kMale;
  p.cases = {{1.80, 80, 1.0, man, true},  {1.80, 80, 1.3, man, true},  {1.55, 50, 1.0, man, true},
             {1.95, 120, 1.0, man, true}, {1.80, 80, 0.5, man, false}, {1.80, 80, 1.5, man, false}};
  if (actuation == controllers::WalkerActuation::kVelocity) {
    for (SearchCase& c : p.cases)
      if (!c.gait) c.reaction_time_s = 0.1;
    // t_r 100 ms on every body (the first searches had it on 1.80 m / 80 kg only, and their
    // best fell within 2 s of the start on 1.55 m / 50 kg and 1.95 m / 120 kg).
    p.cases.push_back({1.80, 80, 1.0, man, false, 0.1});
    p.cases.push_back({1.55, 50, 1.0, man, false, 0.1});
    p.cases.push_back({1.95, 120, 1.0, man, false, 0.1});
    // Women too (de Leva's female segments): a search on men alone found a walker whose women
    // nearly all fell in their first 1.5 s at t_r 100 ms (controllers/README.md, sixteenth
    // session).
    for (const auto& [height, mass] : {std::pair{1.60, 55.0}, {1.75, 85.0}, {1.90, 95.0}})
      p.cases.push_back({height, mass, 1.0, models::Sex::kFemale, false, 0.1});
  }
  return p;
}

void add_push_cases(GaitSearchParams* p, int count, int bodies, std::uint64_t body_seed) {
  if (count < 0 || count > 80 || count % 8 != 0)
    throw sim::InvalidArgument("gait search: pushes: expected a multiple of 8 in [0, 80], got " +
                               std::to_string(count));
  if (bodies < 1 || bodies > 16)
    throw sim::InvalidArgument("gait search: push bodies: expected 1 to 16, got " +
                               std::to_string(bodies));
  if (count == 0) return;
  // The pushed bodies: 1.80 m / 80 kg, then walk-sweep's seeded random bodies (seeds body_seed,
  // body_seed + 1, ...), each walking 1.0 m/s.
  models::CharacterSpec named;
  named.height_m = 1.80;
  named.mass_kg = 80;
  named.sex = models::Sex::kMale;
  std::vector<models::CharacterSpec> pushed = {named};
  WalkSweepSpec drawn;
  drawn.bodies = bodies - 1;
  drawn.seed = body_seed;
  drawn.speeds_m_s = {1.0};
  for (const SweepWalk& w : random_sweep_walks(drawn)) pushed.push_back(w.body);
  // push-sweep's phases are k / 10 of the stride; (j + 1/4) / n never is one (10 j + 2.5 = k n
  // has no integer solution).
  const int per_direction = count / 8;
  for (int j = 0; j < per_direction; ++j) {
    for (int k = 0; k < 8; ++k) {
      // Body (j + k) mod K: each body is pushed from every direction as j runs, at phases spread
      // over the stride (a body per direction would tie each body to one direction).
      const models::CharacterSpec& b = pushed[static_cast<std::size_t>((j + k) % bodies)];
      SearchCase c;
      c.height_m = b.height_m;
      c.mass_kg = b.mass_kg;
      c.sex = b.sex;
      c.gait = false;
      c.reaction_time_s = 0.1;
      c.push_force_N = 350;
      c.push_direction_deg = 45.0 * k;
      c.push_phase = (j + 0.25) / per_direction;
      p->cases.push_back(c);
    }
  }
  // The balance feedback a push calls on (torque_walker.h): the swing hip's placement across,
  // the catching step, the speed's lean terms (each once, if not searched already).
  const SearchDimension balance[] = {
      {"/frontal_cd", -0.3, 0.3},
      {"/frontal_cv", 0.0, 0.8},
      {"/max_swing_roll_rad", 0.15, 0.45},
      {"/catch_step_s_per_m_s", 0.0, 1.0},
      {"/catch_side_deadband_m_s", 0.1, 1.0},
      {"/speed_step_gain_rad_per_m_s", 0.0, 0.5},
      {"/speed_recovery_gain_rad_per_m_s", 0.0, 0.5},
  };
  for (const SearchDimension& d : balance) {
    const bool searched =
        std::any_of(p->dimensions.begin(), p->dimensions.end(),
                    [&d](const SearchDimension& e) { return e.pointer == d.pointer; });
    if (!searched) p->dimensions.push_back(d);
  }
}

CandidateResult evaluate_candidate(const GaitSearchParams& p, const std::string& walker_json,
                                   const std::vector<double>& x) {
  CandidateResult r;
  r.x = x;
  r.json = walker_json;
  try {
    controllers::TorqueWalkerParams check;
    controllers::apply_torque_walker_json(walker_json, "candidate", &check);
  } catch (const sim::InvalidArgument&) {
    r.cost = kFallCost * 2 * static_cast<double>(p.cases.size()) + 1;  // not a valid walker
    return r;
  }
  for (const SearchCase& c : p.cases) {
    r.cases.push_back(walk_case(p, c, walker_json));
    r.cost += r.cases.back().cost;
  }
  return r;
}

CandidateResult run_gait_search(const GaitSearchParams& p,
                                const std::function<void(const GenerationReport&)>& on_generation,
                                const std::function<void(double)>& progress) {
  p.validate();
  const std::size_t n = p.dimensions.size();
  const json base = json::parse(p.base_json);
  std::vector<double> mean(n), sd(n);
  for (std::size_t i = 0; i < n; ++i) {
    const SearchDimension& d = p.dimensions[i];
    mean[i] = std::clamp(base.at(json::json_pointer(d.pointer)).get<double>(), d.lo, d.hi);
    sd[i] = (d.hi - d.lo) * p.initial_spread;
  }
  Normal normal(p.seed);
  CandidateResult best;
  best.cost = std::numeric_limits<double>::infinity();
  const int elites = std::max(2, static_cast<int>(std::lround(p.elite_fraction * p.population)));
  for (int g = 0; g < p.generations; ++g) {
    // Draw the whole generation first (the draws do not depend on the threads).
    std::vector<std::vector<double>> xs(static_cast<std::size_t>(p.population));
    for (int k = 0; k < p.population; ++k) {
      std::vector<double>& x = xs[static_cast<std::size_t>(k)];
      x.resize(n);
      for (std::size_t i = 0; i < n; ++i) {
        // The first candidate of each generation is the mean itself.
        const double v = k == 0 ? mean[i] : mean[i] + sd[i] * normal();
        x[i] = std::clamp(v, p.dimensions[i].lo, p.dimensions[i].hi);
      }
    }
    std::vector<CandidateResult> results(static_cast<std::size_t>(p.population));
    std::atomic<int> next{0}, done{0};
    std::mutex progress_mutex;
    auto work = [&]() {
      for (int k = next++; k < p.population; k = next++) {
        const std::vector<double>& x = xs[static_cast<std::size_t>(k)];
        results[static_cast<std::size_t>(k)] =
            evaluate_candidate(p, candidate_json(p.base_json, p.dimensions, x), x);
        const int finished = ++done;
        if (progress) {
          const std::lock_guard<std::mutex> lock(progress_mutex);
          progress((g + static_cast<double>(finished) / p.population) / p.generations);
        }
      }
    };
    std::vector<std::thread> workers;
    for (int t = 0; t < std::min(p.threads, p.population); ++t) workers.emplace_back(work);
    for (std::thread& w : workers) w.join();
    std::vector<int> order(static_cast<std::size_t>(p.population));
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return results[static_cast<std::size_t>(a)].cost < results[static_cast<std::size_t>(b)].cost;
    });
    if (results[static_cast<std::size_t>(order[0])].cost < best.cost)
      best = results[static_cast<std::size_t>(order[0])];
    GenerationReport report;
    report.generation = g;
    report.best_cost = results[static_cast<std::size_t>(order[0])].cost;
    for (std::size_t i = 0; i < n; ++i) {
      double m = 0, s2 = 0;
      for (int e = 0; e < elites; ++e) m += results[static_cast<std::size_t>(order[e])].x[i];
      m /= elites;
      for (int e = 0; e < elites; ++e)
        s2 += std::pow(results[static_cast<std::size_t>(order[e])].x[i] - m, 2);
      // Smoothed update (de Boer et al. 2005) with a floor, so the search keeps exploring.
      mean[i] = 0.7 * m + 0.3 * mean[i];
      sd[i] = std::max(0.7 * std::sqrt(s2 / elites) + 0.3 * sd[i],
                       (p.dimensions[i].hi - p.dimensions[i].lo) / 200);
    }
    for (int e = 0; e < elites; ++e)
      report.elite_mean_cost += results[static_cast<std::size_t>(order[e])].cost / elites;
    report.mean = mean;
    report.sd = sd;
    report.best = best;
    if (on_generation) on_generation(report);
  }
  return best;
}

}  // namespace biodyn::scenarios
