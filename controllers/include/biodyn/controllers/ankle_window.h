#pragma once
/// The ankle torque a foot on the floor can take (the velocity walker's step 7, velocity_walker.h;
/// used by the motion tracker too): what the ground can return with the centre of pressure inside
/// the foot's actual contact points (a `margin` fraction of their extent) under the foot's
/// load. Held to it, a loaded foot stays flat and the body rolls over it as an inverted
/// pendulum, instead of the whole body tipping rigidly about a sole edge, which is what an
/// ankle following an angle target on a loaded foot does.

#include <mujoco/mujoco.h>

#include <vector>

#include "biodyn/controllers/control_frame.h"
#include "biodyn/controllers/joint_groups.h"
#include "biodyn/sim/queries.h"

namespace biodyn::controllers {

/// Limits the torques of `ankle`'s DOFs for the foot bodies `foot` and `toes` (-1: none),
/// from their contacts in `contacts` (this step's floor contacts) and `load_N` (the foot's
/// vertical ground force, N, >= 0), for this step (a torque window in `frame`).
/// `cop_fraction` < 0: the ankle follows its target within the window (zero torque always
/// allowed: a foot already rolled onto its toes or heel has every CoP-consistent torque on one
/// side, and forcing it would push the body up). `cop_fraction` in [0, 1]: the torque puts
/// the CoP at that fraction of the contacts' length from the rear (sideways it is held
/// central). A foot without contacts is left alone. No allocation.
void limit_ankle_to_contacts(ControlFrame* frame, const mjModel& m, const mjData& d,
                             const JointGroup& ankle, int foot, int toes,
                             const std::vector<sim::FloorContact>& contacts, double load_N,
                             double margin, double cop_fraction = -1);

}  // namespace biodyn::controllers
