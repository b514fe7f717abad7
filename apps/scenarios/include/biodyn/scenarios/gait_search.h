#pragma once
/// A cross-entropy search of the torque walker's parameters against human gait (issue 28;
/// Wang, Fleet & Hertzmann 2009 optimise SIMBICON-style controllers the same way): candidates
/// are drawn from a Gaussian over a box of named parameters, each walks a set of cases (bodies
/// and speeds), the cost counts falls, speed errors and how far the gait figures
/// (gait_analysis.h) lie outside the human bands, and the best quarter sets the next Gaussian.
/// Deterministic for a seed, whatever the thread count (each candidate is its own run).

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "biodyn/controllers/torque_walker.h"
#include "biodyn/models/character.h"
#include "biodyn/scenarios/gait_analysis.h"

namespace biodyn::scenarios {

/// One searched parameter: a JSON pointer into the walker's parameters ("/knee_kp",
/// "/states/1/swing_knee_rad") and its range.
struct SearchDimension {
  std::string pointer;
  double lo = 0, hi = 0;
};

/// One walk each candidate makes.
struct SearchCase {
  double height_m = 1.8, mass_kg = 80, speed_m_s = 1.0;
  models::Sex sex = models::Sex::kMale;
  /// Judged on the gait figures (else only on not falling and the speed).
  bool gait = true;
  double reaction_time_s = 0;  ///< s; > 0 replaces every joint's t_r
  /// N; > 0: a push case (judged on surviving it, push_sweep.h): after steady walking, one
  /// pelvis push of this force for push_duration_s from push_direction_deg at push_phase.
  double push_force_N = 0;
  double push_duration_s = 0.2, push_direction_deg = 0, push_phase = 0;
};

struct GaitSearchParams {
  std::string base_json;  ///< the walker's parameters the search starts from (all fields)
  std::vector<SearchDimension> dimensions;
  std::vector<SearchCase> cases;
  /// The walker's actuation the candidates walk with (torque_walker.h).
  controllers::WalkerActuation actuation = controllers::WalkerActuation::kTorque;
  double duration_s = 16;     ///< s per walk
  double analyse_from_s = 6;  ///< s, the gait figures from here (after the start-up)
  int population = 32, generations = 30;
  double elite_fraction = 0.25;
  /// The first Gaussian's SD, as a fraction of each dimension's range (1/6: the box is +-3 SD;
  /// smaller refines a start already good).
  double initial_spread = 1.0 / 6;
  unsigned long long seed = 1;
  int threads = 1;
  void validate() const;  ///< throws sim::InvalidArgument naming the field
};

/// The default search: a double support with push-off put first in the walker's default states,
/// the phases' targets and the leg gains, on 1.80 m / 80 kg at 1.0 and 1.3 m/s and 1.55 m /
/// 50 kg and 1.95 m / 120 kg at 1.0 m/s (judged on the gait), and 1.80 m / 80 kg at 0.5 and
/// 1.5 m/s (judged on walking); with the velocity-based controllers those two walk with
/// t_r = 100 ms, and every body walks 1.0 m/s at t_r = 100 ms too (the reaction time the paper
/// could not reach), among them three women (1.60 m / 55 kg, 1.75 m / 85 kg, 1.90 m / 95 kg).
GaitSearchParams default_gait_search(const std::string& base_json,
                                     controllers::WalkerActuation actuation);

/// Adds `count` push cases to `p` (the ones push-sweep measures: 350 N x 0.2 s at the pelvis,
/// walking 1.0 m/s at t_r 100 ms, 8 directions, the phases between push-sweep's own so that its
/// 8 x 10 table stays a check the search did not see), and the balance feedback's gains to the
/// searched dimensions (those not searched already). `count` in [0, 80], a multiple of 8. The
/// pushed bodies: 1.80 m / 80 kg alone (`bodies` 1), or with `bodies` - 1 of walk-sweep's
/// random bodies from `body_seed` (keep it apart from the seeds the result is checked on).
void add_push_cases(GaitSearchParams* p, int count, int bodies = 1, std::uint64_t body_seed = 3000);

/// What one case of one candidate gave.
struct CaseOutcome {
  bool fell = false;
  double time_fallen_s = 0, speed_m_s = 0;
  double cost = 0;
  std::vector<GaitFigure> figures;  ///< gait cases that did not fall
  std::string push_failure;         ///< push cases: how a push that was not survived ended
};

struct CandidateResult {
  std::vector<double> x;  ///< one value per dimension
  std::string json;       ///< the full parameters
  double cost = 0;
  std::vector<CaseOutcome> cases;
};

struct GenerationReport {
  int generation = 0;
  double best_cost = 0, elite_mean_cost = 0;
  std::vector<double> mean, sd;  ///< the Gaussian the next generation is drawn from
  CandidateResult best;          ///< the best so far (all generations)
};

/// Walks one candidate's cases (a candidate: `walker_json`, the full parameters).
CandidateResult evaluate_candidate(const GaitSearchParams& p, const std::string& walker_json,
                                   const std::vector<double>& x);

/// Runs the search; `on_generation` is called after each generation (progress, logs).
CandidateResult run_gait_search(const GaitSearchParams& p,
                                const std::function<void(const GenerationReport&)>& on_generation,
                                const std::function<void(double)>& progress = {});

/// `base_json` with the dimensions set to `x` (JSON text the walker reads).
std::string candidate_json(const std::string& base_json,
                           const std::vector<SearchDimension>& dimensions,
                           const std::vector<double>& x);

}  // namespace biodyn::scenarios
