#include "biodyn/scenarios/gait_analysis.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "biodyn/controllers/joint_groups.h"
#include "biodyn/mocap_io/gait_events.h"
#include "biodyn/models/rig.h"
#include "biodyn/models/tables.h"
#include "biodyn/scenarios/motion_recorder.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"

namespace biodyn::scenarios {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// What the motion gives per frame: both legs' sagittal angles (deg), the CoM, the trunk's
/// long axis, the pelvis's forward direction (the walking direction, on a treadmill too) and each
/// foot's heel and toe ahead of the pelvis.
struct Kinematics {
  Eigen::MatrixXd angles_deg;  ///< frames x 6: left hip, knee, ankle, right hip, knee, ankle
  Eigen::MatrixXd com;         ///< frames x 3
  Eigen::MatrixXd trunk_axis;  ///< frames x 3, the trunk body's z axis in the world
  Eigen::MatrixXd forward;     ///< frames x 3, the pelvis's x axis made horizontal, unit
  /// frames x 2 (left, right), m: the back / front of the sole ahead of the pelvis along forward
  Eigen::MatrixXd heel_ahead, toe_ahead;
};

Kinematics compute_kinematics(const mjModel& m, const Eigen::MatrixXd& qpos) {
  const models::Rig rig(m);
  for (int side = 0; side < 2; ++side) {
    const models::RigLeg& leg = rig.leg(side);
    if (leg.hip < 0 || leg.knee < 0 || leg.ankle < 0 || !leg.has_sole) {
      throw sim::InvalidArgument(std::string("gait analysis: the model has no ") +
                                 (side == models::kLeft ? "left" : "right") +
                                 " leg with hip, knee, ankle and a sole (a generated character "
                                 "has them: biodyn model)");
    }
  }
  if (rig.trunk_body() < 0) {
    throw sim::InvalidArgument("gait analysis: the model has no trunk body (thorax or trunk)");
  }
  const Eigen::Index frames = qpos.rows();
  Kinematics k;
  k.angles_deg.resize(frames, 6);
  k.com.resize(frames, 3);
  k.trunk_axis.resize(frames, 3);
  k.forward.resize(frames, 3);
  k.heel_ahead.resize(frames, 2);
  k.toe_ahead.resize(frames, 2);
  sim::Data data(m);
  mjData* d = data.get();
  for (Eigen::Index f = 0; f < frames; ++f) {
    for (int q = 0; q < m.nq; ++q) d->qpos[q] = qpos(f, q);
    mj_kinematics(&m, d);
    mj_comPos(&m, d);
    const double* P = d->xmat + 9 * rig.pelvis();
    Eigen::Vector3d forward(P[0], P[3], 0);
    forward =
        forward.norm() > 1e-9 ? Eigen::Vector3d(forward.normalized()) : Eigen::Vector3d::UnitX();
    k.forward.row(f) = forward.transpose();
    const Eigen::Vector3d pelvis(d->xpos + 3 * rig.pelvis());
    for (int side = 0; side < 2; ++side) {
      const models::RigLeg& leg = rig.leg(side);
      const auto& groups = rig.groups();
      const models::JointGroup& hip = groups[static_cast<std::size_t>(leg.hip)];
      const double hip_flexion = hip.ball ? controllers::angles_from_orientation(
                                                hip, sim::relative_orientation(m, *d, hip.body))[0]
                                          : controllers::hinge_angles(m, hip, d->qpos)[0];
      const double knee =
          controllers::hinge_angles(m, groups[static_cast<std::size_t>(leg.knee)], d->qpos)[0];
      const double ankle =
          controllers::hinge_angles(m, groups[static_cast<std::size_t>(leg.ankle)], d->qpos)[0];
      k.angles_deg(f, 3 * side + kGaitHip) = hip_flexion * kDegPerRad;
      k.angles_deg(f, 3 * side + kGaitKnee) = knee * kDegPerRad;
      k.angles_deg(f, 3 * side + kGaitAnkle) = ankle * kDegPerRad;
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> R(d->xmat +
                                                                             9 * leg.foot);
      const Eigen::Vector3d foot(d->xpos + 3 * leg.foot);
      const double mid_y = 0.5 * (leg.sole.y_min + leg.sole.y_max);
      const Eigen::Vector3d heel = foot + R * Eigen::Vector3d(leg.sole.x_min, mid_y, leg.sole.z);
      const Eigen::Vector3d toe = foot + R * Eigen::Vector3d(leg.sole.x_max, mid_y, leg.sole.z);
      k.heel_ahead(f, side) = (heel - pelvis).dot(forward);
      k.toe_ahead(f, side) = (toe - pelvis).dot(forward);
    }
    for (int c = 0; c < 3; ++c) k.com(f, c) = d->subtree_com[c];  // body 0: the whole body
    const double* R = d->xmat + 9 * rig.trunk_body();
    k.trunk_axis.row(f) << R[2], R[5], R[8];
  }
  return k;
}

/// Runs of `on` frames as [first, last] frame pairs, after filling gaps and dropping runs
/// shorter than kContactDebounce_s.
std::vector<std::pair<Eigen::Index, Eigen::Index>> contact_runs(const std::vector<bool>& on,
                                                                const std::vector<double>& t) {
  std::vector<std::pair<Eigen::Index, Eigen::Index>> runs;
  const Eigen::Index n = static_cast<Eigen::Index>(on.size());
  for (Eigen::Index f = 0; f < n;) {
    if (!on[static_cast<std::size_t>(f)]) {
      ++f;
      continue;
    }
    const Eigen::Index start = f;
    while (f < n && on[static_cast<std::size_t>(f)]) ++f;
    if (!runs.empty() &&
        t[static_cast<std::size_t>(start)] - t[static_cast<std::size_t>(runs.back().second)] <
            kContactDebounce_s) {
      runs.back().second = f - 1;  // a gap too short to be a swing
    } else {
      runs.emplace_back(start, f - 1);
    }
  }
  runs.erase(std::remove_if(runs.begin(), runs.end(),
                            [&](const auto& r) {
                              return t[static_cast<std::size_t>(r.second)] -
                                         t[static_cast<std::size_t>(r.first)] <
                                     kContactDebounce_s;
                            }),
             runs.end());
  return runs;
}

/// Frames where column `c` of `v` is the largest (sign +1) or smallest (-1) within
/// kEventWindow_s on either side.
std::vector<Eigen::Index> extrema(const Eigen::MatrixXd& v, Eigen::Index c,
                                  const std::vector<double>& t, double sign) {
  std::vector<Eigen::Index> out;
  const Eigen::Index n = v.rows();
  for (Eigen::Index f = 1; f + 1 < n; ++f) {
    bool best = true;
    for (Eigen::Index g = f - 1;
         best && g >= 0 &&
         t[static_cast<std::size_t>(f)] - t[static_cast<std::size_t>(g)] <= kEventWindow_s;
         --g)
      best = sign * v(f, c) >= sign * v(g, c);
    for (Eigen::Index g = f + 1;
         best && g < n &&
         t[static_cast<std::size_t>(g)] - t[static_cast<std::size_t>(f)] <= kEventWindow_s;
         ++g)
      best = sign * v(f, c) > sign * v(g, c);
    // An extremum at the motion's ends may lie outside it: not an event.
    if (best && t[static_cast<std::size_t>(f)] - t.front() > kEventEdge_s &&
        t.back() - t[static_cast<std::size_t>(f)] > kEventEdge_s)
      out.push_back(f);
  }
  return out;
}

/// Per foot, per frame: on the floor. From the ground force when given; else (Zeni et al.
/// 2008, which holds on a treadmill too) from the heel strike, where the heel is furthest ahead
/// of the pelvis, to the toe off, where the toe is furthest behind it.
std::array<std::vector<bool>, 2> foot_contact(const GaitInput& in, const Kinematics& k) {
  std::array<std::vector<bool>, 2> on;
  const Eigen::Index frames = in.qpos.rows();
  for (int side = 0; side < 2; ++side) {
    std::vector<bool>& o = on[static_cast<std::size_t>(side)];
    o.assign(static_cast<std::size_t>(frames), false);
    if (in.foot_force_N.cols() > 0) {
      for (Eigen::Index f = 0; f < frames; ++f)
        o[static_cast<std::size_t>(f)] = in.foot_force_N(f, side) > kFootLoaded_N;
      continue;
    }
    const std::vector<Eigen::Index> strikes = extrema(k.heel_ahead, side, in.times_s, +1);
    const std::vector<Eigen::Index> offs = extrema(k.toe_ahead, side, in.times_s, -1);
    for (Eigen::Index s : strikes) {
      const auto off = std::upper_bound(offs.begin(), offs.end(), s);
      if (off == offs.end()) break;
      for (Eigen::Index f = s; f < *off; ++f) o[static_cast<std::size_t>(f)] = true;
    }
  }
  return on;
}

/// Linear interpolation of column `c` of `values` at time `t`.
double value_at(const std::vector<double>& times, const Eigen::MatrixXd& values, Eigen::Index c,
                double t) {
  const auto next = std::upper_bound(times.begin(), times.end(), t);
  if (next == times.begin()) return values(0, c);
  if (next == times.end()) return values(values.rows() - 1, c);
  const auto hi = static_cast<Eigen::Index>(next - times.begin()), lo = hi - 1;
  const double u = (t - times[static_cast<std::size_t>(lo)]) /
                   (times[static_cast<std::size_t>(hi)] - times[static_cast<std::size_t>(lo)]);
  return (1 - u) * values(lo, c) + u * values(hi, c);
}

/// Largest value of column `c` over frames with times in [t0, t1].
double max_between(const std::vector<double>& times, const Eigen::MatrixXd& values, Eigen::Index c,
                   double t0, double t1) {
  double best = std::max(value_at(times, values, c, t0), value_at(times, values, c, t1));
  for (std::size_t f = 0; f < times.size(); ++f) {
    if (times[f] > t0 && times[f] < t1)
      best = std::max(best, values(static_cast<Eigen::Index>(f), c));
  }
  return best;
}

double pearson(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const Eigen::VectorXd x = a.array() - a.mean(), y = b.array() - b.mean();
  const double den = std::sqrt(x.squaredNorm() * y.squaredNorm());
  return den > 0 ? x.dot(y) / den : kNaN;
}

/// One foot's cycle: strike, toe off, next strike, and the other foot's toe off and strike
/// inside it (NaN when not seen).
struct Cycle {
  int side = 0;
  double t0 = 0, toe_off = 0, t1 = 0;
  double other_off = kNaN, other_strike = kNaN;
};

std::vector<Cycle> find_cycles(const GaitInput& in, const std::array<std::vector<bool>, 2>& on) {
  const std::vector<double>& t = in.times_s;
  std::array<std::vector<std::pair<Eigen::Index, Eigen::Index>>, 2> runs = {contact_runs(on[0], t),
                                                                            contact_runs(on[1], t)};
  std::vector<Cycle> cycles;
  for (int side = 0; side < 2; ++side) {
    const auto& mine = runs[static_cast<std::size_t>(side)];
    const auto& other = runs[static_cast<std::size_t>(1 - side)];
    for (std::size_t r = 0; r + 1 < mine.size(); ++r) {
      if (mine[r].first == 0) continue;  // on the floor from the start: no strike seen
      Cycle c;
      c.side = side;
      c.t0 = t[static_cast<std::size_t>(mine[r].first)];
      c.toe_off = t[static_cast<std::size_t>(mine[r].second)];
      c.t1 = t[static_cast<std::size_t>(mine[r + 1].first)];
      if (c.t0 < in.from_s || c.t1 > in.to_s) continue;
      for (const auto& o : other) {
        const double off = t[static_cast<std::size_t>(o.second)];
        const double strike = t[static_cast<std::size_t>(o.first)];
        if (std::isnan(c.other_off) && off > c.t0 && off < c.toe_off) c.other_off = off;
        if (std::isnan(c.other_strike) && strike > c.t0 && strike < c.t1 && o.first > 0)
          c.other_strike = strike;
      }
      cycles.push_back(c);
    }
  }
  return cycles;
}

/// The issue's bands (issue 28, "Must show"), then the reported references (references.md).
std::vector<GaitFigure> judged_figures(const GaitAnalysis& a) {
  const char* issue = "issue 28";
  const char* refs = "references.md (Winter 2009; Perry & Burnfield 2010)";
  return {
      {"knee at mid-stance", "deg", issue, a.knee_midstance_deg, -5, 15},
      {"knee loading-response peak", "deg", issue, a.knee_loading_peak_deg, 10, 25},
      {"knee swing peak", "deg", issue, a.knee_swing_peak_deg, 55, 67},
      {"hip flexion-extension range", "deg", issue, a.hip_range_deg, 35, 50},
      {"ankle plantarflexion at toe off", "deg", issue, a.ankle_plantarflexion_toe_off_deg, 10, 25},
      {"trunk lean, largest", "deg", issue, a.trunk_lean_max_deg, 0, 10},
      {"stance", "% cycle", issue, a.stance_percent, 55, 65},
      {"cadence", "steps/min", issue, a.cadence_steps_per_min, 100, 120},
      {"hip curve correlation", "r", issue, a.correlation[kGaitHip], 0.9, 1},
      {"knee curve correlation", "r", issue, a.correlation[kGaitKnee], 0.9, 1},
      {"ankle curve correlation", "r", refs, a.correlation[kGaitAnkle], 0.6, 1},
      {"double support", "% cycle", refs, a.double_support_percent, 15, 25},
      {"CoM vertical excursion", "m", refs, a.com_excursion_m, 0.03, 0.05},
  };
}

/// How many of judged_figures() the issue asks for (the rest are reported).
constexpr std::size_t kIssueFigures = 10;

}  // namespace

bool GaitAnalysis::all_met() const {
  if (cycles == 0) return false;
  for (std::size_t i = 0; i < std::min(kIssueFigures, figures.size()); ++i) {
    if (!figures[i].met()) return false;
  }
  return true;
}

void normative_gait_curves(Eigen::MatrixXd* mean_deg, Eigen::MatrixXd* sd_deg) {
  const std::vector<models::NormativeGaitRow>& rows = models::normative_gait();
  mean_deg->resize(kGaitCyclePoints, 3);
  sd_deg->resize(kGaitCyclePoints, 3);
  const std::size_t n = rows.size();
  auto value = [&](std::size_t i, int j, bool sd) {
    const models::NormativeGaitRow& r = rows[i];
    const double means[3] = {r.hip_mean_deg, r.knee_mean_deg, r.ankle_mean_deg};
    const double sds[3] = {r.hip_sd_deg, r.knee_sd_deg, r.ankle_sd_deg};
    return sd ? sds[j] : means[j];
  };
  // Periodic cubic Hermite: the slope at a key point from its neighbours (the cycle wraps, row
  // 0 and row n-1 are the same instant).
  auto slope = [&](std::size_t i, int j, bool sd) {
    const std::size_t prev = i == 0 ? n - 2 : i - 1, next = i == n - 1 ? 1 : i + 1;
    const double tp = i == 0 ? rows[prev].percent - 100 : rows[prev].percent;
    const double tn = i == n - 1 ? rows[next].percent + 100 : rows[next].percent;
    return (value(next, j, sd) - value(prev, j, sd)) / (tn - tp);
  };
  for (int p = 0; p < kGaitCyclePoints; ++p) {
    const double x = 100.0 * p / (kGaitCyclePoints - 1);
    std::size_t i = 0;
    while (i + 2 < n && rows[i + 1].percent <= x) ++i;
    const double h = rows[i + 1].percent - rows[i].percent, u = (x - rows[i].percent) / h;
    const double h00 = 2 * u * u * u - 3 * u * u + 1, h10 = u * u * u - 2 * u * u + u;
    const double h01 = -2 * u * u * u + 3 * u * u, h11 = u * u * u - u * u;
    for (int j = 0; j < 3; ++j) {
      for (bool sd : {false, true}) {
        const double v = h00 * value(i, j, sd) + h10 * h * slope(i, j, sd) +
                         h01 * value(i + 1, j, sd) + h11 * h * slope(i + 1, j, sd);
        (sd ? *sd_deg : *mean_deg)(p, j) = v;
      }
    }
  }
}

GaitInput gait_input(const mjModel& m, const RecordedMotion& rec, double from_s) {
  GaitInput in;
  in.model = &m;
  in.times_s = rec.times_s;
  in.qpos = rec.qpos;
  in.foot_force_N.resize(rec.frame_count(), 2);
  for (int side = 0; side < 2; ++side)
    in.foot_force_N.col(side) = rec.ground_force_N[static_cast<std::size_t>(side)].col(2);
  in.from_s = from_s;
  return in;
}

GaitAnalysis analyse_gait(const GaitInput& in) {
  if (in.model == nullptr || in.qpos.cols() != in.model->nq ||
      static_cast<std::size_t>(in.qpos.rows()) != in.times_s.size() ||
      (in.foot_force_N.cols() > 0 &&
       (in.foot_force_N.cols() != 2 || in.foot_force_N.rows() != in.qpos.rows()))) {
    throw sim::InvalidArgument(
        "gait analysis: expected qpos frames x nq with one time per frame and foot forces "
        "frames x 2 (or none); got qpos " +
        std::to_string(in.qpos.rows()) + " x " + std::to_string(in.qpos.cols()) + ", " +
        std::to_string(in.times_s.size()) + " times, forces " +
        std::to_string(in.foot_force_N.rows()) + " x " + std::to_string(in.foot_force_N.cols()));
  }
  const Kinematics k = compute_kinematics(*in.model, in.qpos);
  const std::array<std::vector<bool>, 2> on = foot_contact(in, k);
  std::vector<Cycle> all = find_cycles(in, on);
  GaitAnalysis a;
  a.events = in.foot_force_N.cols() > 0 ? "ground force" : "heel and toe vs pelvis (Zeni 2008)";
  if (all.empty()) {
    throw sim::InvalidArgument(
        "gait analysis: no complete gait cycle (heel strike to the next strike of the same foot, "
        "from " +
        std::to_string(in.from_s) + " s) in the motion's " + std::to_string(in.times_s.size()) +
        " frames: is it a walk?");
  }
  std::vector<double> lengths;
  for (const Cycle& c : all) lengths.push_back(c.t1 - c.t0);
  std::nth_element(lengths.begin(),
                   lengths.begin() + static_cast<std::ptrdiff_t>(lengths.size() / 2),
                   lengths.end());
  const double median = lengths[lengths.size() / 2];
  std::vector<Cycle> cycles;
  for (const Cycle& c : all) {
    const double len = c.t1 - c.t0;
    if (len >= kCycleMinOfMedian * median && len <= kCycleMaxOfMedian * median) {
      cycles.push_back(c);
    } else {
      ++a.cycles_left_out;
    }
  }
  a.cycles = static_cast<int>(cycles.size());
  const std::vector<double>& t = in.times_s;
  // Per-frame trunk lean and both-feet contact, resampled per cycle with the angles.
  Eigen::MatrixXd per_frame(in.qpos.rows(), 8);
  per_frame.leftCols(6) = k.angles_deg;
  for (Eigen::Index f = 0; f < in.qpos.rows(); ++f) {
    const Eigen::Vector3d axis = k.trunk_axis.row(f).transpose();
    per_frame(f, 6) = std::atan2(axis.dot(k.forward.row(f).transpose()), axis.z()) * kDegPerRad;
    per_frame(f, 7) = on[0][static_cast<std::size_t>(f)] && on[1][static_cast<std::size_t>(f)];
  }
  Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(kGaitCyclePoints, 3), sum2 = sum;
  double lean_sum = 0, distance = 0, time = 0;
  for (const Cycle& c : cycles) {
    const double len = c.t1 - c.t0;
    // Over the ground (on a treadmill the CoM stays: speed ~0).
    const Eigen::Vector2d p0(value_at(t, k.com, 0, c.t0), value_at(t, k.com, 1, c.t0));
    const Eigen::Vector2d p1(value_at(t, k.com, 0, c.t1), value_at(t, k.com, 1, c.t1));
    distance += (p1 - p0).norm();
    time += len;
    const Eigen::MatrixXd cyc =
        mocap_io::resample_cycle(t, per_frame, c.t0, c.t1, kGaitCyclePoints);
    const Eigen::MatrixXd joints = cyc.middleCols(3 * c.side, 3);
    sum += joints;
    sum2 += joints.array().square().matrix();
    lean_sum += cyc.col(6).mean();
    a.trunk_lean_max_deg = std::max(a.trunk_lean_max_deg, cyc.col(6).cwiseAbs().maxCoeff());
    a.double_support_percent += 100.0 * cyc.col(7).head(kGaitCyclePoints - 1).mean();
    a.stance_percent += 100.0 * (c.toe_off - c.t0) / len;
    a.hip_range_deg += joints.col(kGaitHip).maxCoeff() - joints.col(kGaitHip).minCoeff();
    const Eigen::Index knee = 3 * c.side + kGaitKnee;
    const double mid = std::isfinite(c.other_off) && std::isfinite(c.other_strike)
                           ? 0.5 * (c.other_off + c.other_strike)
                           : 0.5 * (c.t0 + c.toe_off);
    a.knee_midstance_deg += value_at(t, k.angles_deg, knee, mid);
    a.knee_loading_peak_deg += max_between(t, k.angles_deg, knee, c.t0, mid);
    a.knee_swing_peak_deg += max_between(t, k.angles_deg, knee, c.toe_off, c.t1);
    a.ankle_plantarflexion_toe_off_deg -=
        value_at(t, k.angles_deg, 3 * c.side + kGaitAnkle, c.toe_off);
  }
  const double n = std::max(1, a.cycles);
  a.mean_deg = sum / n;
  a.sd_deg = (sum2 / n - a.mean_deg.array().square().matrix()).cwiseMax(0.0).cwiseSqrt();
  for (double* v :
       {&a.double_support_percent, &a.stance_percent, &a.hip_range_deg, &a.knee_midstance_deg,
        &a.knee_loading_peak_deg, &a.knee_swing_peak_deg, &a.ankle_plantarflexion_toe_off_deg}) {
    *v /= n;
  }
  a.trunk_lean_mean_deg = lean_sum / n;
  a.cycle_s = time / n;
  a.cadence_steps_per_min = a.cycle_s > 0 ? 2 * 60.0 / a.cycle_s : 0;
  a.speed_m_s = time > 0 ? distance / time : 0;
  a.stride_length_m = a.speed_m_s * a.cycle_s;
  // The CoM's vertical range per step: between consecutive strikes of either foot.
  std::vector<double> strikes;
  for (const Cycle& c : cycles) strikes.push_back(c.t0);
  std::sort(strikes.begin(), strikes.end());
  int steps = 0;
  for (std::size_t s = 0; s + 1 < strikes.size(); ++s) {
    if (strikes[s + 1] - strikes[s] > 0.75 * a.cycle_s) continue;  // a cycle left out between
    double lo = value_at(t, k.com, 2, strikes[s]), hi = lo;
    for (std::size_t f = 0; f < t.size(); ++f) {
      if (t[f] <= strikes[s] || t[f] >= strikes[s + 1]) continue;
      lo = std::min(lo, k.com(static_cast<Eigen::Index>(f), 2));
      hi = std::max(hi, k.com(static_cast<Eigen::Index>(f), 2));
    }
    a.com_excursion_m += hi - lo;
    ++steps;
  }
  a.com_excursion_m = steps > 0 ? a.com_excursion_m / steps : kNaN;  // one cycle: no step
  Eigen::MatrixXd norm_mean, norm_sd;
  normative_gait_curves(&norm_mean, &norm_sd);
  for (int j = 0; j < 3; ++j) {
    a.correlation[static_cast<std::size_t>(j)] = pearson(a.mean_deg.col(j), norm_mean.col(j));
    a.rms_from_normative_deg[static_cast<std::size_t>(j)] =
        std::sqrt((a.mean_deg.col(j) - norm_mean.col(j)).squaredNorm() / kGaitCyclePoints);
  }
  a.figures = judged_figures(a);
  return a;
}

}  // namespace biodyn::scenarios
