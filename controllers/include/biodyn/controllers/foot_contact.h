#pragma once
/// The foot-contact constraint of paper §4.1: at foot strike a weld fixes the stance foot to
/// the ground from its current pose (no snap); it is released at lift-off. It gives the
/// relative-orientation controllers knowledge of the global orientation and stops the foot
/// sliding. A plain weld also glues: it pulls the foot down when the body lifts, holds a heel
/// down while the toes push, and holds sideways beyond friction. biodyn's weld modes:
///
///  - kOff: contacts only.
///  - kHonest (default): the weld stays on only while the net ground wrench on the foot
///    (weld plus the foot's and toes' floor contacts, about the sole centre) is one that
///    unilateral frictional contact through the sole could give: compressive (F_z >= 0),
///    inside the friction cone (|F_xy| <= mu F_z), centre of pressure inside the sole
///    rectangle, torsion within mu F_z r (r = half the sole diagonal, an upper bound on
///    torsional friction). Only the net wrench moves the foot, so a weld that merely shares
///    load with the contacts is honest; one that holds the foot down, holds a heel down
///    while the toes push, or holds it sideways beyond friction is not. A step in
///    which an active weld breaks any of these is undone and repeated with that weld off
///    (CharacterController does this), so no kept step ever has a weld in tension.
///  - kGlue: the paper's plain weld, on from strike to the controller's lift-off.
///
/// Engagement ("strike"): the controller wants the foot in stance, the foot body touches the
/// floor at >= 3 points (flat), and its origin moves slower than `engage_max_speed_m_s`;
/// after an honest release not before `reengage_delay_s`. The weld is set from the foot's
/// pose at that moment, so it holds the foot where it is.
///
/// Weld wrench read-out: the generalized force of the weld rows (J' efc_force) projected on the
/// free root gives the net force and moment it applies to the foot, independent of MuJoCo's
/// internal row scaling.

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "biodyn/models/rig.h"
#include "biodyn/sim/queries.h"

namespace biodyn::controllers {

enum class WeldMode { kOff, kHonest, kGlue };
const char* to_string(WeldMode mode);
/// "off", "honest" or "glue"; throws sim::InvalidArgument naming `field` and the value.
WeldMode parse_weld_mode(const std::string& text, const std::string& field = "weld");

struct FootWeldParams {
  WeldMode mode = WeldMode::kHonest;
  double engage_max_speed_m_s = 0.005;  ///< m/s, foot-origin speed below which a strike counts
  double engage_max_angular_speed_rad_s = 0.05;  ///< rad/s
  int engage_min_contacts = 3;    ///< floor contact points on the foot body (flat foot)
  double reengage_delay_s = 0.1;  ///< s, after an honest release
  /// Honest mode works with a margin inside the contact wrench cone (WeldWrench::margin):
  /// a weld is switched off, without undoing anything, once the margin falls below
  /// `release_margin`, and switched on only where the contacts alone give at least
  /// `engage_margin`. Releasing before the edge keeps the planned torques valid for the
  /// contacts alone, so the hand-over is smooth; the undo-and-repeat is the backstop.
  double release_margin = 0.25;
  double engage_margin = 0.5;
  /// Fraction of body weight a foot must carry to count as loaded (margin 0 at this load).
  double min_load_fraction = 0.05;
  void validate() const;  ///< throws sim::InvalidArgument
};

/// The wrench one weld applied to its foot in one step.
struct WeldWrench {
  Eigen::Vector3d force_W = Eigen::Vector3d::Zero();   ///< N, on the foot, world frame
  Eigen::Vector3d moment_W = Eigen::Vector3d::Zero();  ///< N m, about the sole centre, world
  /// N and N m about the sole centre, world: weld plus the floor contacts of foot and toes.
  Eigen::Vector3d ground_force_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d ground_moment_W = Eigen::Vector3d::Zero();
  bool tension = false;  ///< ground wrench not one unilateral contact could give (see above)
  /// N, how far outside: max(-F_z, |F_xy| - mu F_z, CoP and torsion excess as forces).
  double tension_excess_N = 0;
  /// Distance inside the contact wrench cone of the ground wrench, normalised: 1 = centred,
  /// loaded and far from sliding; <= 0 at an edge, unloaded or sliding.
  double margin = -1;
};

/// What the foot welds carry from one step to the next (a copyable aggregate; the welds'
/// activation and anchors are model fields, kept by sim::DataCheckpoint).
struct FootWeldState {
  std::array<bool, 2> stance = {true, true};           ///< the controller's wish per foot
  std::array<double, 2> released_at_s = {-1e9, -1e9};  ///< s, the last honest release
  std::array<WeldWrench, 2> wrench;                    ///< the last measured wrenches
};

/// The foot-contact welds of a rig's feet (equalities foot_weld_l/r).
class FootWelds {
 public:
  /// Throws sim::InvalidArgument for invalid params, and models::RigError if the mode is not
  /// off and the rig has no foot welds, feet or floor.
  FootWelds(const mjModel& m, const models::Rig& rig, FootWeldParams params);

  const FootWeldParams& params() const { return params_; }
  /// Changes the mode (releases every weld when switched to off).
  void set_mode(mjModel& m, WeldMode mode);

  /// All welds off, stance wanted on both feet.
  void reset(mjModel& m);

  /// The controller's wish: stance (may weld at strike) or swing (released now).
  void set_stance(mjModel& m, int side, bool stance);
  bool stance(int side) const { return state_.stance[static_cast<std::size_t>(side)]; }
  bool active(const mjModel& m, int side) const;

  /// Call inside the control callback (after mj_step1): switches on welds of stance feet
  /// that struck, from their current pose (active from the next step).
  void engage_at_strikes(mjModel& m, const mjData& d);

  /// After mj_step2: each foot's weld wrench, ground wrench (weld + contacts) and margin in
  /// this step. Returns the side of an active weld in tension, or -1.
  int measure(const mjModel& m, const mjData& d);
  const WeldWrench& wrench(int side) const { return state_.wrench[static_cast<std::size_t>(side)]; }

  /// Honest mode, after a kept step: switch off welds whose margin fell below
  /// release_margin (effective from the next step).
  void release_near_edges(mjModel& m, double t);

  /// Honest mode: switch `side` off after it went into tension at time `t`.
  void release_for_tension(mjModel& m, int side, double t);

  const models::Sole& sole(int side) const { return feet_[static_cast<std::size_t>(side)].sole; }
  int foot_body(int side) const { return feet_[static_cast<std::size_t>(side)].body; }

  const FootWeldState& state() const { return state_; }
  void restore(const FootWeldState& state) { state_ = state; }

 private:
  struct Foot {  // fixed for the model
    int eq = -1, body = -1;
    models::Sole sole;
    double mu = 1.0;  // friction with the floor
  };
  void engage(mjModel& m, const mjData& d, const Foot& foot);

  FootWeldParams params_;
  FootWeldState state_;
  int floor_geom_ = -1;
  std::array<Foot, 2> feet_;
  std::vector<mjtNum> qfrc_;          // nv scratch
  std::vector<mjtNum> jacobian_row_;  // nv scratch: one efc_J row, dense
  std::vector<sim::FloorContact> contacts_;
  double weight_ = 0;  // N, body weight
  int root_body_ = 1;  // the free root
  int root_dof_ = 0;
};

}  // namespace biodyn::controllers
