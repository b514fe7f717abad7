#include "biodyn/mocap_io/gait_events.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "biodyn/mocap_io/inverse_dynamics.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"

namespace biodyn::mocap_io {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// m: the height of the foot's heel point (back of the sole, middle of its width) per frame.
std::vector<double> heel_heights(const mjModel& m, const Eigen::MatrixXd& qpos, int side) {
  const models::Rig rig(m);
  const models::RigLeg& leg = rig.leg(side);
  if (leg.foot < 0 || !leg.has_sole) {
    throw sim::InvalidArgument(std::string("heel strikes: the model has no ") +
                               (side == models::kLeft ? "left" : "right") + " foot with a sole");
  }
  const Eigen::Vector3d heel_B(leg.sole.x_min, 0.5 * (leg.sole.y_min + leg.sole.y_max), leg.sole.z);
  sim::Data data(m);
  mjData* d = data.get();
  std::vector<double> z(static_cast<std::size_t>(qpos.rows()));
  for (Eigen::Index f = 0; f < qpos.rows(); ++f) {
    for (int k = 0; k < m.nq; ++k) d->qpos[k] = qpos(f, k);
    mj_kinematics(&m, d);
    const double* R = d->xmat + 9 * leg.foot;  // row-major: the z row is R[6..8]
    z[static_cast<std::size_t>(f)] =
        d->xpos[3 * leg.foot + 2] + R[6] * heel_B.x() + R[7] * heel_B.y() + R[8] * heel_B.z();
  }
  return z;
}

/// Times the heel comes down through kHeelStrikeHeight_m above its lowest after rising more
/// than kHeelLiftHeight_m above it (interpolated between frames).
std::vector<double> kinematic_strikes(const std::vector<double>& z,
                                      const std::vector<double>& times_s) {
  std::vector<double> strikes;
  if (z.empty()) return strikes;
  const double lowest = *std::min_element(z.begin(), z.end());
  const double threshold = lowest + kHeelStrikeHeight_m;
  bool lifted = false;
  for (std::size_t f = 0; f < z.size(); ++f) {
    if (z[f] > lowest + kHeelLiftHeight_m) lifted = true;
    if (lifted && z[f] <= threshold) {
      double t = times_s[f];
      if (f > 0 && z[f - 1] > threshold) {
        t = times_s[f - 1] +
            (times_s[f] - times_s[f - 1]) * (z[f - 1] - threshold) / (z[f - 1] - z[f]);
      }
      strikes.push_back(t);
      lifted = false;
    }
  }
  return strikes;
}

/// The plates' strikes of `side`: runs of loaded frames (assigned or not) in which the load is
/// assigned to `side` more often than to the other foot; a run from the motion's first frame has
/// no onset in the motion.
std::vector<HeelStrike> plate_strikes(const Eigen::MatrixXi& plate_foot,
                                      const std::vector<double>& times_s, int side) {
  std::vector<HeelStrike> out;
  const Eigen::Index frames = plate_foot.rows();
  for (Eigen::Index p = 0; p < plate_foot.cols(); ++p) {
    for (Eigen::Index f = 0; f < frames;) {
      if (plate_foot(f, p) == kPlateUnloaded) {
        ++f;
        continue;
      }
      const Eigen::Index start = f;
      int mine = 0, other = 0;
      for (; f < frames && plate_foot(f, p) != kPlateUnloaded; ++f) {
        mine += plate_foot(f, p) == side;
        other += plate_foot(f, p) == 1 - side;
      }
      if (start == 0 || mine <= other) continue;
      HeelStrike s;
      s.time_s = times_s[static_cast<std::size_t>(start)];
      s.plate = static_cast<int>(p);
      s.kinematic_time_s = kNaN;
      s.plate_off_time_s = times_s[static_cast<std::size_t>(f - 1)];
      out.push_back(s);
    }
  }
  return out;
}

}  // namespace

std::vector<HeelStrike> heel_strikes(const mjModel& m, const Eigen::MatrixXd& qpos,
                                     const std::vector<double>& times_s, int side,
                                     const Eigen::MatrixXi& plate_foot) {
  if (qpos.cols() != m.nq || static_cast<std::size_t>(qpos.rows()) != times_s.size() ||
      (plate_foot.cols() > 0 && plate_foot.rows() != qpos.rows())) {
    throw sim::InvalidArgument("heel strikes: qpos must be frames x nq (" + std::to_string(m.nq) +
                               "), got " + std::to_string(qpos.rows()) + " x " +
                               std::to_string(qpos.cols()) + ", with " +
                               std::to_string(times_s.size()) + " times and " +
                               std::to_string(plate_foot.rows()) + " plate rows");
  }
  if (side != models::kLeft && side != models::kRight) {
    throw sim::InvalidArgument("heel strikes: side must be left (0) or right (1), got " +
                               std::to_string(side));
  }
  std::vector<double> kinematic = kinematic_strikes(heel_heights(m, qpos, side), times_s);
  std::vector<HeelStrike> strikes = plate_strikes(plate_foot, times_s, side);
  for (HeelStrike& s : strikes) {
    auto nearest = kinematic.end();
    for (auto it = kinematic.begin(); it != kinematic.end(); ++it) {
      if (std::abs(*it - s.time_s) <= kStrikeMatchWindow_s &&
          (nearest == kinematic.end() || std::abs(*it - s.time_s) < std::abs(*nearest - s.time_s)))
        nearest = it;
    }
    if (nearest != kinematic.end()) {
      s.kinematic_time_s = *nearest;
      kinematic.erase(nearest);
    }
  }
  for (double t : kinematic) strikes.push_back({t, -1, t, kNaN});
  std::sort(strikes.begin(), strikes.end(),
            [](const HeelStrike& a, const HeelStrike& b) { return a.time_s < b.time_s; });
  return strikes;
}

Eigen::MatrixXd resample_cycle(const std::vector<double>& times_s, const Eigen::MatrixXd& values,
                               double t0_s, double t1_s, int points) {
  if (points < 2 || times_s.empty() || static_cast<std::size_t>(values.rows()) != times_s.size() ||
      !(t0_s >= times_s.front() && t1_s <= times_s.back() && t0_s < t1_s)) {
    throw sim::InvalidArgument("gait cycle: [" + std::to_string(t0_s) + ", " +
                               std::to_string(t1_s) + "] s must lie within the " +
                               std::to_string(values.rows()) +
                               " frames' times, with at least 2 "
                               "points (got " +
                               std::to_string(points) + ")");
  }
  Eigen::MatrixXd out(points, values.cols());
  for (int i = 0; i < points; ++i) {
    const double t = t0_s + (t1_s - t0_s) * i / (points - 1);
    const auto next = std::upper_bound(times_s.begin(), times_s.end(), t);
    const std::size_t hi =
        std::min<std::size_t>(static_cast<std::size_t>(next - times_s.begin()), times_s.size() - 1);
    const std::size_t lo = hi > 0 ? hi - 1 : 0;
    const double span = times_s[hi] - times_s[lo];
    const double u = span > 0 ? std::clamp((t - times_s[lo]) / span, 0.0, 1.0) : 0.0;
    out.row(i) = (1.0 - u) * values.row(static_cast<Eigen::Index>(lo)) +
                 u * values.row(static_cast<Eigen::Index>(hi));
  }
  return out;
}

}  // namespace biodyn::mocap_io
