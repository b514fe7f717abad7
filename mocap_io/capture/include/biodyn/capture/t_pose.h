#pragma once
/// The T-pose a capture starts with (thesis: the subject stands in a T-pose so the labelling can
/// find every marker; labelling.h), and a motion led in from it for synthetic captures.

#include <mujoco/mujoco.h>

#include <vector>

#include "biodyn/mocap_io/motion_csv.h"

namespace biodyn::capture {

/// The character's T-pose: its standing pose (qpos0) with both arms raised sideways to the
/// horizontal, palms down.
std::vector<double> t_pose_qpos(const mjModel& model);

/// `motion` preceded by the subject standing `hold_s` in a T-pose where the motion begins (its
/// first position and heading), then moving into the motion's first frame over `blend_s` (a
/// smoothstep in joint space). Times keep the motion's spacing and start at its first time.
/// Throws sim::InvalidArgument for hold < 0, blend <= 0 or a motion of fewer than 2 frames.
mocap_io::Motion with_t_pose_lead_in(const mjModel& model, const mocap_io::Motion& motion,
                                     double hold_s, double blend_s);

}  // namespace biodyn::capture
