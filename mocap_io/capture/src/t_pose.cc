#include "biodyn/capture/t_pose.h"

#include <Eigen/Geometry>
#include <cmath>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"

namespace biodyn::capture {

std::vector<double> t_pose_qpos(const mjModel& model) {
  std::vector<double> q(model.qpos0, model.qpos0 + model.nq);
  // Body frames are parallel to the world in the standing pose (x forward, y left, z up): the
  // left arm turns +90 degrees about x (down -> left), the right arm -90 degrees.
  for (const auto& [name, sign] : {std::pair<const char*, double>{"shoulder_l", 1.0},
                                   std::pair<const char*, double>{"shoulder_r", -1.0}}) {
    const int j = mj_name2id(&model, mjOBJ_JOINT, name);
    if (j < 0 || model.jnt_type[j] != mjJNT_BALL) continue;  // a body without arms
    const double half = sign * M_PI / 4;
    const auto a = static_cast<std::size_t>(model.jnt_qposadr[j]);
    q[a] = std::cos(half);
    q[a + 1] = std::sin(half);
    q[a + 2] = 0;
    q[a + 3] = 0;
  }
  return q;
}

mocap_io::Motion with_t_pose_lead_in(const mjModel& model, const mocap_io::Motion& motion,
                                     double hold_s, double blend_s) {
  if (!(hold_s >= 0) || !(blend_s > 0) || !std::isfinite(hold_s + blend_s))
    throw sim::InvalidArgument("T-pose lead-in: hold must be >= 0 s and blend > 0 s, got " +
                               std::to_string(hold_s) + " and " + std::to_string(blend_s));
  if (motion.frame_count() < 2)
    throw sim::InvalidArgument("T-pose lead-in: the motion has fewer than 2 frames");
  const int nq = model.nq, root = model.jnt_qposadr[0];
  const Eigen::RowVectorXd first = motion.qpos.row(0);
  // The T-pose where the motion begins, facing its first heading, standing at qpos0's height.
  std::vector<double> t = t_pose_qpos(model);
  const Eigen::Quaterniond q0(first(root + 3), first(root + 4), first(root + 5), first(root + 6));
  const Eigen::Vector3d forward = q0 * Eigen::Vector3d::UnitX();
  const double yaw = std::atan2(forward.y(), forward.x());
  t[static_cast<std::size_t>(root)] = first(root);
  t[static_cast<std::size_t>(root + 1)] = first(root + 1);
  t[static_cast<std::size_t>(root + 3)] = std::cos(yaw / 2);
  t[static_cast<std::size_t>(root + 4)] = 0;
  t[static_cast<std::size_t>(root + 5)] = 0;
  t[static_cast<std::size_t>(root + 6)] = std::sin(yaw / 2);
  const double dt = (motion.times_s.back() - motion.times_s.front()) / (motion.frame_count() - 1);
  const int lead = static_cast<int>(std::lround((hold_s + blend_s) / dt));
  mocap_io::Motion out;
  out.columns = motion.columns;
  out.comments = motion.comments;
  out.qpos.resize(lead + motion.frame_count(), nq);
  std::vector<double> row(static_cast<std::size_t>(nq));
  for (int f = 0; f < lead; ++f) {
    const double s = f * dt;
    // Smoothstep from the T-pose to the first frame: no jump in position or velocity at either
    // end of the blend.
    const double x = std::clamp((s - hold_s) / blend_s, 0.0, 1.0), a = x * x * (3 - 2 * x);
    sim::interpolate_qpos(model, t.data(), first, a, row.data());
    for (int i = 0; i < nq; ++i) out.qpos(f, i) = row[static_cast<std::size_t>(i)];
    out.times_s.push_back(motion.times_s.front() + s);
  }
  out.qpos.bottomRows(motion.frame_count()) = motion.qpos;
  for (double time : motion.times_s) out.times_s.push_back(time + lead * dt);
  return out;
}

}  // namespace biodyn::capture
