// Sampling-based tracking of a captured motion (samcon.h).
#include "biodyn/scenarios/samcon.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <thread>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/mocap_scenario.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/random.h"
#include "biodyn/sim/simulation.h"

namespace biodyn::scenarios {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
/// Costs are summed this many times per window (evenly spaced, the last at its end).
constexpr int kCostPointsPerWindow = 2;
/// A child's offsets are centred on this fraction of its parent's.
constexpr double kCarry = 0.5;
/// A path's cost: its last window's plus this fraction of the parent's (older windows fade).
constexpr double kParentCostDecay = 0.5;

std::uint64_t sample_key(std::uint64_t seed, int window, int attempt, int parent, int child) {
  return sim::stream_key(seed, {window, attempt, parent, child});
}

/// Per DOF: the offsets' standard deviation (0 for the root and joints not sampled).
Eigen::VectorXd offset_sigmas(const mjModel& m, const models::Rig& rig, const SamconParams& p) {
  Eigen::VectorXd sigma = Eigen::VectorXd::Zero(m.nv);
  const std::vector<models::JointGroup>& groups = rig.groups();
  const int back = rig.lower_back();
  for (std::size_t i = 0; i < groups.size(); ++i) {
    const models::JointGroup& g = groups[i];
    double s = 0;
    if (g.name.rfind("hip", 0) == 0) s = p.sigma_hip_rad;
    if (g.name.rfind("knee", 0) == 0) s = p.sigma_knee_rad;
    if (g.name.rfind("ankle", 0) == 0) s = p.sigma_ankle_rad;
    // The lower back (the lumbar, or the gait model's trunk) and the thorax.
    if (static_cast<int>(i) == back || g.name == "thorax") s = p.sigma_trunk_rad;
    sigma.segment(g.dof_begin, g.dof_count).setConstant(s);
  }
  return sigma;
}

/// One thread's own simulation and tracking scenario.
struct Worker {
  std::unique_ptr<sim::Simulation> sim;
  std::unique_ptr<MocapScenario> scenario;
  std::vector<double> pose;  // nq scratch
};

std::unique_ptr<Worker> make_worker(const ScenarioConfig& config,
                                    const models::PhysicsOptions& physics) {
  auto w = std::make_unique<Worker>();
  w->sim = std::make_unique<sim::Simulation>(sim::Model::from_string(
      models::to_mjcf(models::generate_character(config.model_spec()), physics), "<character>"));
  w->scenario = std::make_unique<MocapScenario>(w->sim.get(), config);
  w->pose.resize(static_cast<size_t>(w->sim->model().nq));
  return w;
}

/// How far the scenario's body is from the motion now (samcon.h's scales).
double distance_cost(Worker* w, const SamconParams& p) {
  const MocapScenario& s = *w->scenario;
  const mjModel& m = w->sim->model();
  const mjData& d = w->sim->data();
  const controllers::MotionTracker::Error e = s.tracking_error();
  controllers::motion_pose_at(m, s.tracked_motion(), d.time, w->pose.data());
  const int a = m.jnt_qposadr[s.rig().root_joint()];
  const double dz = d.qpos[a + 2] - w->pose[static_cast<size_t>(a + 2)];
  const Eigen::Quaterniond have(d.qpos[a + 3], d.qpos[a + 4], d.qpos[a + 5], d.qpos[a + 6]);
  const Eigen::Quaterniond want(
      w->pose[static_cast<size_t>(a + 3)], w->pose[static_cast<size_t>(a + 4)],
      w->pose[static_cast<size_t>(a + 5)], w->pose[static_cast<size_t>(a + 6)]);
  const double turn = have.angularDistance(want);
  const controllers::TrackedMotion& motion = s.tracked_motion();
  const std::size_t f = motion.frame_at(d.time);
  const sim::CenterOfMass com = sim::center_of_mass(m, d);
  const double dv = (com.velocity_W - motion.com_velocity_W[f]).head<2>().norm();
  const auto sq = [](double x) { return x * x; };
  return sq(e.joint_rms_rad / p.joint_scale_rad) + sq(e.root_horizontal_m / p.root_scale_m) +
         sq(dz / p.root_scale_m) + sq(turn / p.pelvis_scale_rad) + sq(dv / p.com_speed_scale_m_s);
}

/// Restores `from`, holds `offsets` for `steps` steps and saves into `to`; returns the window's
/// cost (infinite at a fall).
double rollout(Worker* w, const ScenarioState& from, const Eigen::VectorXd& offsets, int steps,
               const SamconParams& p, ScenarioState* to) {
  MocapScenario& s = *w->scenario;
  s.restore(from);
  s.set_tracking_offsets(offsets);
  const sim::JointLoadStats start = s.tracking_stats().load;  // plain values: no allocation
  double cost = 0;
  for (int k = 1; k <= steps; ++k) {
    s.step();
    if (s.fell_at_s() >= 0) return kInfinity;
    if (k * kCostPointsPerWindow % steps < kCostPointsPerWindow) cost += distance_cost(w, p);
  }
  // The window's mean squared excess of the worst joint load over 1 (stretches past the
  // meter's 10 ms impact time; sim/joint_load.h), weighted like the distance points.
  const sim::JointLoadStats& end = s.tracking_stats().load;
  const long load_steps = end.steps - start.steps;
  if (load_steps > 0) {
    const double excess = (end.excess_sum - start.excess_sum) / static_cast<double>(load_steps);
    cost += kCostPointsPerWindow * excess / (p.load_scale * p.load_scale);
  }
  s.save(to);
  return cost;
}

/// One kept state of the search tree.
struct Node {
  int parent = -1;          // index in the previous window's nodes
  Eigen::VectorXd offsets;  // held over this window
  double cost = 0;          // decayed path cost
};

}  // namespace

void SamconParams::validate() const {
  const auto check = [](bool ok, const char* field, double v) {
    if (!ok)
      throw sim::InvalidArgument(std::string("samcon ") + field + ", got " + std::to_string(v));
  };
  check(window_s >= 0.01 && window_s <= 1.0, "window: must be in [0.01, 1] s", window_s);
  check(parents >= 1 && parents <= 1000, "parents: must be in [1, 1000]", parents);
  check(children >= 1 && children <= 1000, "children: must be in [1, 1000]", children);
  check(max_attempts >= 1 && max_attempts <= 10, "attempts: must be in [1, 10]", max_attempts);
  check(threads >= 0 && threads <= 256, "threads: must be in [0, 256]", threads);
  for (const double s : {sigma_hip_rad, sigma_knee_rad, sigma_ankle_rad, sigma_trunk_rad})
    check(s >= 0 && s <= 1, "sigma: must be in [0, 1] rad", s);
  for (const double s :
       {joint_scale_rad, root_scale_m, pelvis_scale_rad, com_speed_scale_m_s, load_scale})
    check(s > 0 && std::isfinite(s), "cost scale: must be > 0", s);
}

SamconResult run_samcon(const ScenarioConfig& config, const models::PhysicsOptions& physics,
                        const SamconParams& params, int record_every_steps,
                        const std::function<void(double)>& progress) {
  params.validate();
  if (config.scenario != "mocap" || !config.track) {
    throw sim::InvalidArgument("samcon: needs the mocap scenario with tracking on");
  }
  const auto wall_start = std::chrono::steady_clock::now();
  const int threads = params.threads > 0
                          ? params.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  std::vector<std::unique_ptr<Worker>> workers;
  for (int t = 0; t < threads; ++t) workers.push_back(make_worker(config, physics));
  Worker& main = *workers.front();
  const mjModel& m = main.sim->model();
  const Eigen::VectorXd sigma = offset_sigmas(m, main.scenario->rig(), params);
  const int steps = std::max(1, static_cast<int>(std::lround(params.window_s / m.opt.timestep)));
  SamconResult r;
  r.windows = static_cast<int>(
      std::ceil(main.scenario->motion_length_s() / (steps * m.opt.timestep) - 1e-9));

  // Window 0 starts from the scenario's first state (the motion's first frame, moving).
  std::vector<std::unique_ptr<ScenarioState>> parents;
  parents.push_back(main.scenario->new_state());
  main.scenario->save(parents.back().get());
  std::vector<std::vector<Node>> tree;
  std::vector<Node> last = {Node{-1, Eigen::VectorXd::Zero(m.nv), 0.0}};
  const int max_samples = params.parents * params.children;
  std::vector<std::unique_ptr<ScenarioState>> children(static_cast<size_t>(max_samples));
  for (auto& c : children) c = main.scenario->new_state();
  std::vector<double> cost(static_cast<size_t>(max_samples));
  std::vector<Eigen::VectorXd> offsets(static_cast<size_t>(max_samples), Eigen::VectorXd(m.nv));

  for (int window = 0; window < r.windows; ++window) {
    const int n = static_cast<int>(parents.size()) * params.children;
    bool any = false;
    for (int attempt = 0; attempt < params.max_attempts && !any; ++attempt) {
      const double widen = std::pow(1.5, attempt);
      std::atomic<int> next{0};
      auto work = [&](Worker* w) {
        for (int j = next++; j < n; j = next++) {
          const int p = j / params.children, c = j % params.children;
          sim::RandomStream normal(sample_key(params.seed, window, attempt, p, c));
          Eigen::VectorXd& o = offsets[static_cast<size_t>(j)];
          // Around half the parent's offsets (a correction fades unless renewed); child 0 of
          // the first attempt takes exactly that (never worse than not sampling).
          const Eigen::VectorXd& mean = last[static_cast<size_t>(p)].offsets;
          for (int v = 0; v < m.nv; ++v) {
            const double noise = sigma(v) > 0 ? widen * sigma(v) * normal.normal() : 0.0;
            o(v) = kCarry * mean(v) + (c == 0 && attempt == 0 ? 0.0 : noise);
          }
          const double window_cost = rollout(w, *parents[static_cast<size_t>(p)], o, steps, params,
                                             children[static_cast<size_t>(j)].get());
          cost[static_cast<size_t>(j)] =
              window_cost + kParentCostDecay * last[static_cast<size_t>(p)].cost;
        }
      };
      std::vector<std::thread> pool;
      for (int t = 1; t < threads; ++t)
        pool.emplace_back(work, workers[static_cast<size_t>(t)].get());
      work(&main);
      for (std::thread& t : pool) t.join();
      r.rollouts += n;
      r.steps += static_cast<long>(n) * steps;
      for (int j = 0; j < n; ++j) any = any || std::isfinite(cost[static_cast<size_t>(j)]);
    }
    if (!any) break;  // every child fell, every attempt: the best path ends here
    // Keep the best children by (cost, index): the same whatever the threads did.
    std::vector<int> order(static_cast<size_t>(n));
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return cost[static_cast<size_t>(a)] < cost[static_cast<size_t>(b)];
    });
    std::vector<Node> kept;
    std::vector<std::unique_ptr<ScenarioState>> next_parents;
    for (int j : order) {
      if (static_cast<int>(kept.size()) == params.parents ||
          !std::isfinite(cost[static_cast<size_t>(j)]))
        break;
      kept.push_back(
          Node{j / params.children, offsets[static_cast<size_t>(j)], cost[static_cast<size_t>(j)]});
      next_parents.push_back(std::move(children[static_cast<size_t>(j)]));
      children[static_cast<size_t>(j)] = main.scenario->new_state();
    }
    tree.push_back(last);
    last = std::move(kept);
    parents = std::move(next_parents);
    r.windows_kept_up = window + 1;
    if (progress) progress(static_cast<double>(window + 1) / r.windows);
  }
  tree.push_back(last);
  if (!parents.empty() && r.windows_kept_up > 0) {
    main.scenario->restore(*parents.front());
    r.search_joint_rms_rad = main.scenario->tracking_stats().joint_rms_rad();
    r.search_root_max_m = main.scenario->tracking_stats().root_max_m;
  }

  // The best leaf's chain of offsets, replayed from the start on one worker.
  r.offsets_rad = Eigen::MatrixXd::Zero(r.windows_kept_up, m.nv);
  int node = 0;  // nodes are sorted: 0 is the best
  r.cost = tree.back().empty() ? kInfinity : tree.back()[0].cost;
  for (int window = r.windows_kept_up; window >= 1; --window) {
    const Node& nd = tree[static_cast<size_t>(window)][static_cast<size_t>(node)];
    r.offsets_rad.row(window - 1) = nd.offsets.transpose();
    node = nd.parent;
  }
  std::unique_ptr<Worker> fresh = make_worker(config, physics);
  MocapScenario& s = *fresh->scenario;
  double peak = 0;
  const int total_steps = r.windows * steps;
  r.qpos.resize((total_steps + record_every_steps - 1) / record_every_steps, m.nq);
  for (int k = 0; k < total_steps; ++k) {
    const int window = k / steps;
    if (k % steps == 0) {
      s.set_tracking_offsets(window < r.windows_kept_up
                                 ? Eigen::VectorXd(r.offsets_rad.row(window).transpose())
                                 : Eigen::VectorXd::Zero(m.nv));
    }
    if (k % record_every_steps == 0) {
      const mjData& d = fresh->sim->data();
      const auto row = static_cast<Eigen::Index>(r.times_s.size());
      r.times_s.push_back(d.time);
      for (int q = 0; q < m.nq; ++q) r.qpos(row, q) = d.qpos[q];
    }
    s.step();
    peak = std::max(peak, s.pipeline()->last_report().joints.max_torque_ratio);
    if (s.fell_at_s() >= 0) break;
  }
  r.qpos.conservativeResize(static_cast<Eigen::Index>(r.times_s.size()), m.nq);  // a fall ends it
  const TrackingReport report = s.tracking_report();
  r.fell_at_s = report.fell_at_s;
  r.joint_rms_rad = report.stats.joint_rms_rad();
  r.joint_max_rad = report.stats.joint_max_rad;
  r.root_max_m = report.stats.root_max_m;
  r.peak_torque_ratio = peak;
  r.joint_load = joint_load_report(m, report.stats.load);
  r.start_swing_lift_rad = report.start_swing_lift_rad;
  r.start_swing_clearance_m = report.start_swing_clearance_m;
  r.residual_force_rms_N = report.stats.residual_force_rms_N();
  r.residual_force_peak_N = report.stats.residual_force_peak_N;
  r.residual_moment_rms_Nm = report.stats.residual_moment_rms_Nm();
  r.residual_moment_peak_Nm = report.stats.residual_moment_peak_Nm;
  r.simulated_s = static_cast<double>(r.steps) * m.opt.timestep;
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return r;
}

}  // namespace biodyn::scenarios
