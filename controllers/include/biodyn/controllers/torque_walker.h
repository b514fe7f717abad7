#pragma once
/// The torque walker: SIMBICON (Yin, Loken & van de Panne 2007) on the generated character,
/// with the torso torque distributed as in Coros et al. 2010 — the walker that walks. The
/// velocity-based walker (velocity_walker.h, the paper's own method) is the other state machine
/// on the same gait core (gait_core.h); it does not walk yet (controllers/README.md).
///
/// Per step (a ControlDriver: every DOF gets a prescribed torque in the control frame, so the
/// joint controllers' muscle limits tau_max and reaction-time rate limit still apply):
///  - A finite-state machine of phases per step (the paper's target states, Fig. 2), data in
///    TorqueWalkerParams::phases (JSON "states"): each phase ends on time or, the last one, at
///    the swing foot's strike (gait core: touching the floor after having left it), which swaps
///    the legs. The default gait has two: "early swing" (time), "late swing" (strike), as
///    SIMBICON; a double support phase (swing_foot_down) can be put first.
///  - Every joint except the hips: PD towards its phase target, tau = kp (theta_d - theta) -
///    kp damping_time omega. The swing ankle holds the sole level in the heading frame (gait
///    core, toes up by toe_up), so the foot neither scuffs nor stubs whatever the shank does.
///  - Swing hip: PD on the swing thigh's orientation in the heading frame, its pitch and roll
///    given by the balance feedback theta = theta_0 + c_d d + c_v v (d, v: CoM position
///    relative to the stance ankle and CoM velocity, heading frame) in both planes.
///  - Constrained stepping (paper §4.2; plan_steps): a step with a planned length puts the
///    swing ankle on its target instead: the 2D IK triangle hip-knee-ankle in the heading
///    frame's sagittal plane (gait core) gives the swing thigh's pitch and the knee angle (an
///    unreachable target gives the straight leg pointing at it, the closest reachable state).
///    The roll stays with the balance feedback.
///  - Base-polygon balance (paper §4.3, gait core; base_polygon_rule): when the CoM's projection
///    leaves the tolerance polygon, the swing thigh pitches (rolls) at least far enough for the
///    paper's step d = 4(c - b_P)/3 - 2 foot_length ahead, behind or aside.
///  - Stance hip: the pelvis's orientation in the world (upright, pitched pelvis_pitch, facing
///    the heading) by a virtual torso torque tau_torso; the stance hip takes
///    tau_stance = -tau_torso - tau_swing - tau_lumbar so that the joints' reactions on the
///    pelvis sum to tau_torso (the lower back's reaction included, the lumbar's or on the
///    paper's lower-body model the trunk's: the upper body is half the mass). Optionally its
///    roll and yaw parts scale with the stance foot's share of the feet's load
///    (stance_hip_load_share). In a flight it holds its thigh upright instead
///    (flight_stance_thigh).
/// Gains are for an 80 kg body and scale with the body mass. Nothing acts on the root: the
/// torso torque is made by the hips against the legs, and the feet hold by contact only.
///
/// A step redone at the same time (honest welds) drives again from the state the first call
/// left: the heading and the strikes advance once, but a placed step's IK rates (a finite
/// difference over time) read zero in the redone step. Kept: fixing it changes the stepping
/// stones' figures.

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "biodyn/controllers/control_driver.h"
#include "biodyn/controllers/gait_core.h"
#include "biodyn/controllers/joint_groups.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/queries.h"

namespace biodyn::controllers {

/// One phase of a step (a target state, paper Fig. 2), written for the swing leg and mirrored
/// for either side. Angles in rad; the swing hip's is the swing thigh's pitch forward of
/// vertical in the heading frame, before the balance feedback; the swing ankle's is added to the
/// level sole (in a swing_foot_down phase it is the joint angle itself: the foot is on the floor).
struct TorqueWalkerPhase {
  std::string name;
  bool ends_at_strike = false;  ///< JSON "end": "time" (after duration_s) or "strike"
  double duration_s = 0.3;      ///< a time phase's length at reference_speed_m_s
  /// The phase shortens by this much per m/s of commanded speed above the reference (people
  /// step faster as they walk faster, not only longer).
  double duration_per_m_s = 0;
  double swing_hip_rad = 0;
  double swing_knee_rad = 0;
  double swing_ankle_rad = 0;
  double stance_knee_rad = 0;
  double stance_ankle_rad = 0;  ///< dorsiflexion positive
  /// Double support: the swing foot stays in stance (the welds may hold it) and a planned
  /// step's IK waits for the next state.
  bool swing_foot_down = false;
};

/// The documented default gait: "early swing" then "late swing" (SIMBICON's two states).
std::vector<TorqueWalkerPhase> default_torque_walker_phases();

/// Parameters of the torque walker; angles in rad, gains in N m/rad for an 80 kg body. The
/// defaults were found by a cross-entropy search on the walker (12 s walks at 0.5-1.5 m/s on
/// three bodies, from standing, with a human cadence band; controllers/README.md).
struct TorqueWalkerParams {
  /// The step's phases in order (JSON "states"); the last one ends at the strike (validate()).
  std::vector<TorqueWalkerPhase> phases = default_torque_walker_phases();
  double sagittal_cd = 0.246;         ///< rad/m of CoM ahead of the stance ankle
  double sagittal_cv = 0.225;         ///< rad per m/s of forward CoM velocity
  double frontal_cd = -0.020;         ///< rad/m of CoM beside the stance ankle
  double frontal_cv = 0.480;          ///< rad per m/s of sideways CoM velocity
  double swing_hip_out_rad = -0.075;  ///< swing thigh roll outwards (the step width offset)
  /// A free step's swing thigh rolls outwards at most this far (balance feedback and
  /// base-polygon rule). Unbounded, a 350 N x 0.2 s sideways push (capture point 0.3-0.4 m out)
  /// got a side step 0.84-0.92 m wide whose slanted leg gave way at the next strike; bounded, the
  /// body is caught over two or three side steps. It binds without a push too: in the first
  /// step from standing and in turns faster than ~30 deg/s (controllers/README.md).
  double max_swing_roll_rad = 0.25;
  double toe_up_rad = 0.070;  ///< swing sole pitch, toes up
  /// s per m/s: a swing time phase ends this much sooner per m/s that the CoM moves forward
  /// faster than the walk's own speed (the last free step's mean, or the command if higher)
  /// beyond 0.25 m/s (the CoM's own speed swings by ~0.2 m/s within a step): a push
  /// from behind gets its catching step sooner (step-timing adaptation, Khadiv et al. 2016),
  /// the phase lasting at least half its length. Not before 3 free steps after start_time_s,
  /// while stopping, in turns faster than ~6 deg/s or on planned stones. 0: off
  /// (controllers/README.md).
  double catch_step_s_per_m_s = 0.7;
  /// m/s: the CoM's sideways speed (either way) beyond this shortens the swing's time phase
  /// as well, by catch_step_s_per_m_s per m/s beyond it (the same conditions; off with it at
  /// 0), the larger of the forward and sideways excesses counting. After a side
  /// push the side step, or the crossover when the push is towards the stance leg, comes
  /// sooner: at t_r 100 ms the crossover after a push at the end of a swing came 0.48 s later,
  /// the capture point already 27 cm beyond it. A steady walk's own sideways speed stays
  /// within ~0.2 m/s (an unsettled start's can pass 0.4). It costs some diagonal pushes from
  /// behind. 0: off (controllers/README.md).
  double catch_side_deadband_m_s = 0.4;
  double pelvis_pitch_rad = 0.125;  ///< forward lean of the pelvis in the world
  double start_pitch_rad = 0.073;   ///< extra lean for the first start_time_s (from standing)
  double start_time_s = 1.934;
  /// When the start ends, the speed integral takes over its extra lean (the integral is raised
  /// to at least start_pitch_rad at the first free step after start_time_s), so the lean does
  /// not drop as the walk gets going. The velocity driver's integral takes ~8 s to build the
  /// lean its speed needs; arriving at 0.85 m/s of a 1.0 m/s command, small bodies stalled at
  /// the terrain's 5 cm step up (controllers/README.md). false: the start's lean just ends.
  bool start_pitch_handover = false;
  /// From standing, until start_time_s, the lean's feed-forward and the phases' lengths are the
  /// reference speed's whatever the command; the command's come after. The start's own lean
  /// tips the body forward: at t_r 100 ms the velocity driver's tall bodies fell in the start
  /// at 1.5 m/s (the command's lean on top and its shorter swings brought the first steps down
  /// ahead of the body) and at 0.5-0.6 m/s (its lean taken away: they fell backwards); random
  /// bodies at t_r 100 ms, 4 seeds of 10: 62 -> 80 of 80 at 1.5 m/s, 79 -> 80 at 0.5 m/s
  /// (controllers/README.md, seventeenth session). Off for the torque walker: its random stones
  /// walked 106 -> 102 of 150 with it (lengths only, seeds 5000, 7000, 2000).
  bool start_at_reference_speed = false;
  /// Gait initiation from standing: before the first lift people push the CoM towards the
  /// stance foot (the anticipatory postural adjustment; Crenna & Frigo 1991, Winter 1995). For
  /// start_shift_s the standing balance (poses.h) holds the capture point over the first stance
  /// foot, both feet down, its targets due start_shift_reach_s after the start; then the walker
  /// lifts the swing foot (walk_scenario.cc). A short push, not a whole shift: after the
  /// velocity driver's 0.08 s the CoM is 3-4 mm on its way, moving at 0.09 m/s, and it is 5 cm
  /// towards the stance foot at the first strike (9 cm towards the swing side without). At
  /// t_r 100 ms light bodies fell without it; shifts of 0.12-0.3 s felled others in their first
  /// steps (controllers/README.md, eighteenth session). 0: the first swing lifts at once (the
  /// torque walker's default).
  double start_shift_s = 0;
  double start_shift_reach_s = 0.2;
  double torso_kp = 1273;
  double hip_kp = 434;
  double knee_kp = 218;
  double ankle_kp = 52;
  /// The legs with a foot on the floor (the stance leg; the trailing leg in a double support):
  /// their knee's and ankle's (flexion) gains. A person's stance knee and ankle are stiff
  /// (extensors, soleus) while the swing leg's are compliant.
  double stance_knee_kp = 218;
  double stance_ankle_kp = 52;
  /// The stance knee also carries this fraction of the body weight as a feed-forward torque,
  /// J' f with f the weight pressed through the ankle (Coros et al. 2010's virtual force;
  /// shared equally in a double support): it holds the body without the crouch a PD needs to
  /// make that torque. 0: off. Torque actuation only (with velocity actuation the stance leg is
  /// a spring and the whole-body solve carries the body).
  double stance_weight_support = 0;
  double toe_kp = 30;
  double trunk_kp = 600;        ///< lumbar, thorax; trunk (the paper's lower-body model)
  double arm_kp = 100;          ///< shoulders, clavicles
  double distal_kp = 50;        ///< neck, head, elbows, forearms, wrists
  double damping_time_s = 0.1;  ///< kd = kp damping_time_s
  /// Speed regulation (walking-notes.md: speed is set mostly by the forward lean). The gait
  /// walks at about reference_speed_m_s with the lean above; a commanded speed v adds
  /// speed_lean_rad_per_m_s (v - reference) at once, and after every step
  /// speed_integral_rad_per_m (v - v_step) t_step, v_step the step's mean CoM speed along the
  /// heading (the lean held within +-speed_lean_limit_rad, the integral within
  /// +-speed_integral_limit_rad).
  double reference_speed_m_s = 1.0;
  double speed_lean_rad_per_m_s = 0.1;
  double speed_integral_rad_per_m = 0.03;
  double speed_lean_limit_rad = 0.2;
  /// The integral's own bound, rad (within the lean's). A command the gait cannot reach (the
  /// velocity-based driver's speed levels off at 0.85-1.1 m/s at t_r 100 ms) winds the integral
  /// up over tens of seconds, and that lean tipped short bodies over at 1.0 and 1.5 m/s (60 s
  /// walks of 10 random bodies x 3 speeds, honest: 6 and 4 of 30 fell; bounded at 0.1 rad, 2
  /// and 1; the named body's pushes 78 and 43 of 80 either way). It costs speed where the
  /// integral did reach: 1.0 m/s at t_r 100 ms walks 0.85 m/s instead of 0.94. The step and
  /// recovery terms still lean up to speed_lean_limit_rad (controllers/README.md). Above the
  /// reference the feed-forward lean counts against this bound (the integral is held within
  /// it less speed_lean_rad_per_m_s (v - reference)): at 1.5 m/s the velocity driver's short
  /// women leaned 0.05 + 0.1 rad and fell at 8-12 s (t_r 100 ms, 6 of 40 random walks; with
  /// start_at_reference_speed too, none), and the named body walks 0.87 m/s instead of 1.00.
  /// The velocity driver's bound is 0.08 rad: at 0.1 short heavy women (1.56-1.61 m,
  /// 70-77 kg) still fell, their step speed running away forwards at the bound after 8-40 s, 6
  /// of 300 random walks at t_r 100 ms; at 0.08 none of 420 (controllers/README.md, eighteenth
  /// session).
  double speed_integral_limit_rad = 0.2;
  /// Where the step term below acts (weighted by its fade: below the reference speed), the
  /// integral counts a step's deficit v - v_step only within +-this, m/s (0: whole). A walk's
  /// own steps are within ~0.1 m/s of the command; a push's are 0.3-0.9 m/s off, and counted
  /// whole they wound the lean up: at commands of 0.5-0.7 m/s most failed pushes were 'speed
  /// not back within 10 % in 4 strides' (controllers/README.md). At and above the reference
  /// the integral is the only regulator and counts the whole deficit (bounded there, it cost
  /// pushes at t_r 100 ms); while stopping too.
  double speed_integral_step_limit_m_s = 0.2;
  /// The regulation's proportional part, for commands slower than the reference: after every
  /// step whose speed the integral counts, the lean gains k (v - v_step) until the next such
  /// step, held within +-speed_step_limit_rad. k is speed_step_gain_rad_per_m_s at commands
  /// speed_step_fade_m_s or more below reference_speed_m_s, fading linearly to 0 at the
  /// reference (and 0 while stopping). The integral alone swings slowly about a slow command
  /// (0.5 m/s: 0.22-0.78 m/s over ~25 s) and the step term damps it; at and above the
  /// reference the integral alone tracks, and the step term cost pushes (controllers/README.md).
  /// 0: off.
  double speed_step_gain_rad_per_m_s = 0.2;
  double speed_step_limit_rad = 0.05;
  double speed_step_fade_m_s = 0.2;
  /// Speed recovery after a near stop: a step slower than the command by more than
  /// speed_recovery_deadband_m_s adds speed_recovery_gain_rad_per_m_s times the excess to the
  /// step term's lean until the next counted step, where the step term has faded out (weighted
  /// 1 - its fade: at and above reference_speed_m_s in full; not while stopping), once
  /// the walk has been at the command (not in a start or after a command change). A push from
  /// the front can leave the body walking on the spot or slowly backwards (-0.1 m/s); the
  /// integral alone took 6 steps to lean it forward again, and the speed was not back in 4
  /// strides. The deadband is wide (0.6 m/s): the torque walker's at 0.3 also acted on the scatter
  /// of fast walkers at t_r 100 ms and cost held-out pushes (controllers/README.md). The
  /// velocity driver's is 0.3 m/s: at t_r 100 ms its integral sits at its bound, and at 0.6 a
  /// push from the front was not answered (the named body's 180 deg pushes 0 of 10 with the
  /// bound at 0.08 rad; 7 of 10 at 0.3 m/s; eighteenth session). 0: off.
  double speed_recovery_gain_rad_per_m_s = 0.2;
  double speed_recovery_deadband_m_s = 0.6;
  /// The frontal counterpart: after every step the swing thigh's roll gains
  /// lateral_integral_rad_per_m times the CoM's sideways travel in that step (heading frame), so
  /// a steady sideways drift places the feet against it (held within +-speed_lean_limit_rad).
  double lateral_integral_rad_per_m = 0.05;
  /// The drift integral counts a step's sideways travel within +-this, m (0: whole). A drift is
  /// a few cm a step; a sideways push's 0.3-1 m counted whole rolled the feet until the body had
  /// walked back across, at 0.3-0.5 m/s for 3-5 strides (controllers/README.md).
  double lateral_integral_step_limit_m = 0.02;
  /// Constrained stepping: in early swing the ankle is held this high above its target.
  double step_clearance_m = 0.06;
  /// Constrained stepping: the IK aims short of the target by this times the ankle's
  /// overshoot (in late swing: its miss either way), correcting the PD's lag.
  double placement_gain = 2.0;
  /// Constrained stepping: in late swing a target still out of reach on the floor keeps the
  /// ankle at the clearance height for up to this long (the hip catches up) before it comes
  /// down at the closest reachable point. 0.15 until the speed regulation's step term: with the
  /// body at the command when the stones begin (not still faster), the paper's 0.60 m first
  /// stone was beyond reach at the strike at 0.6-0.9 m/s; with 0.2 it is reached.
  double placed_wait_s = 0.2;
  /// Constrained stepping: until the swing ankle is this far ahead of the stance ankle, the
  /// knee flexes at least as far as the phase's swing knee (a far target's IK leg is nearly
  /// straight, and its toes scuff the floor at mid-swing).
  double placed_tuck_m = -0.1;
  /// Constrained stepping, speed by preview: during a plan the lean's feed-forward follows the
  /// speed the stones ask, the mean length of this and the next two stones over the last free
  /// step's time, by this gain: the feed-forward (speed_lean_rad_per_m_s) is for the speed
  /// v_cmd + gain x (v_plan - v_cmd), the difference held within +-0.3 m/s (so up to +-0.9 m/s
  /// from the command at the default gain). Short stones ahead lean the body back before it
  /// reaches them. 0: off. Measured on random sequences (biodyn stones-sweep, lengths only):
  /// 8 -> 14 of 24 on the tuning seed, 18 -> 26 of 50 held out (controllers/README.md).
  double plan_speed_gain = 3;
  /// Stopping: while braking, the swing thigh pitches this much further per m/s of forward
  /// CoM speed (the foot lands ahead of the CoM); once the CoM is slower than stop_speed_m_s
  /// at a strike, the next step brings the feet side by side.
  double stop_brake_rad_per_m_s = 0.0;
  double stop_speed_m_s = 0.325;
  /// The stop speed is lower by this per m/s that the command was below reference_speed_m_s
  /// when the stop was asked. The stop was tuned from 1.0 m/s; from a slow command (now held by
  /// the speed step term) the closing step came too early and some bodies swayed backwards and
  /// fell after it (controllers/README.md, Stopping).
  double stop_speed_per_m_s = 0.15;
  /// Base-polygon balance (paper §4.3): the tolerance polygon is the support polygon (the
  /// feet's floor contacts) scaled about its centre so that its edges lie this fraction of the
  /// polygon's extent from the centre; when the CoM's projection leaves it during a swing, the
  /// strike is moved to at least base_polygon_step() ahead (or behind, or aside).
  double tolerance_fraction = 0.25;
  bool base_polygon_rule = true;
  /// The rule's step back (CoM behind the tolerance band and moving back) only when the capture
  /// point, x_CoM + v_x / omega_0 with omega_0 = sqrt(g / CoM height) (Pratt et al. 2006), is
  /// behind the support polygon's rear edge: otherwise the body comes to rest over its feet
  /// without a step. Ungated, a 350 N push from the front at a strike slowed the body to ~0.2 m/s
  /// backwards, the rule stepped back, the CoM rolled forward again onto the other foot and the
  /// walker swung that loaded leg: a fall ~1.1 s after the onset on most bodies
  /// (controllers/README.md). false: the paper's rule as it is.
  bool back_step_capture_point = true;
  /// The rule's step back swings with the landing phase's knee (the last state's swing knee,
  /// nearly straight) instead of the phase's own: the early swing's knee (60 deg) folds the
  /// foot far behind the hip, and under velocity actuation it struck the floor there, 0.3 m
  /// behind the rule's step, leaving the front foot loaded for the next swing (a 350 N push from
  /// the front: velocity 180 deg 7 -> 9 of 10). The torque walker's back steps need the fold:
  /// with this on, its t_r 100 ms pushes went 70 -> 63 of 80 (controllers/README.md).
  bool back_step_landing_knee = false;
  /// The stance hip's roll and yaw torque (the torso torque with the swing hip's and the lower
  /// back's reactions, about the heading's forward and vertical axes) in proportion to the stance
  /// foot's share of the load both feet carry (vertical ground force, weld and contacts, the last
  /// step's), in full while they carry less than a tenth of the body weight; the pitch part
  /// stays whole. SIMBICON's stance hip assumes a planted foot; on an unloaded one the torque
  /// swings the leg instead of the pelvis. After a catching step 30 cm wide (a diagonal push from
  /// behind at t_r 100 ms) the new stance hip, holding the pelvis level with the CoM far inside
  /// its foot while the trailing foot still carried the weight, slid that foot 40 cm outwards
  /// and lifted it, and the body fell. On: the named body's 350 N x 0.2 s pushes at t_r 100 ms
  /// 70 -> 73 of 80 (every direction >= 8), 23 held-out bodies 602 -> 625 of 920; at t_r 20 ms
  /// 80 -> 80 and 876 -> 875. Off by default: 0.1 s pushes from the front at t_r 20 ms then
  /// first fail at 600-750 N in 6 of 10 phases (at 900-950 N in 4 without; mean over the
  /// phases 955 -> 770 N). Shared whole (pitch too) it cost the stones their pitch control
  /// (lengths-only sequences 106 -> 93 of 150). Torque actuation only (velocity actuation's
  /// stance hip holds the pelvis only while its foot touches the floor). false: the whole torso
  /// torque on the stance hip (SIMBICON; Coros et al. 2010); controllers/README.md, nineteenth
  /// session.
  bool stance_hip_load_share = false;
  /// In the air (neither foot touches the floor) the body's angular momentum cannot change: a
  /// hip torque turns the pelvis one way and the legs the other, and the light legs take the
  /// turn. The stance hip then holds its thigh upright in the heading frame (roll and pitch 0,
  /// facing the heading; damped relative to the pelvis) instead of the pelvis, so the legs stay
  /// under the body for the landing. It acts at once: a strike's bounce (both feet off for one
  /// 2 ms step in a steady walk) gets it for that step; waiting 20 ms lost the gain. Why: at t_r
  /// 100 ms a hard push vaults the body over its straightening stance leg into a flight (18 of
  /// 19 falls of a 1.65 m / 60 kg body at 350 N x 0.2 s had one, 1 of its 21 survivals), where
  /// the whole torso torque splayed the legs 0.75 m apart. On: the named body's pushes at t_r
  /// 100 ms 70 -> 73 of 80, 20 held-out bodies 523 -> 629 of 800, 10 more not looked at before
  /// 309 -> 343 of 400. Torque actuation only; velocity actuation ignores it (its stance hip
  /// drops its velocity wish in the air). controllers/README.md, twentieth session. false: the
  /// torso torque in the air too (SIMBICON).
  bool flight_stance_thigh = true;
  void validate() const;  ///< throws sim::InvalidArgument naming the field
};

/// Overrides the fields a JSON object gives (keys are the member names above, e.g.
/// {"hip_kp": 900, "states": [...]}; "states", the phases, replaces the whole list); unknown
/// keys, non-numbers and values out of range are errors naming `source`, the field, the rule and
/// the value (sim::InvalidArgument). On error `params` is unchanged.
void apply_torque_walker_json(const std::string& json_text, const std::string& source,
                              TorqueWalkerParams* params);
/// Every field as a JSON object that apply_torque_walker_json reads back identically.
std::string torque_walker_json(const TorqueWalkerParams& params);

/// How the walker's targets become joint torques.
enum class WalkerActuation {
  /// PD torques (SIMBICON), every DOF torque-specified through the joint controllers' limits.
  kTorque,
  /// The paper's velocity-based controllers (§3): each joint's target with an optimal time
  /// t = damping_time_s (w = theta v / t), its torque from the whole-body solve
  /// (sim/hybrid_dynamics.h); the stance hip holds the pelvis's world orientation (§4.1) and the
  /// swing thigh its heading-frame goal as velocity wishes; the legs with a foot on the floor
  /// are springs with the PD gains (prescribing their accelerations closes a loop through the
  /// ground that the solve meets by launching the body; controllers/README.md).
  kVelocity,
};
/// "torque" / "velocity".
const char* to_string(WalkerActuation a);
/// Parses "torque" | "velocity"; throws sim::InvalidArgument naming `field` and the value.
WalkerActuation parse_walker_actuation(const std::string& text, const std::string& field);

/// The defaults for velocity actuation (WalkerActuation::kVelocity): the torque defaults' gait
/// with a double support first and the phases and leg gains from `biodyn walk-search
/// --controller velocity` (controllers/README.md says how they were found). With the torque
/// defaults the velocity-actuated walker fell at 4 s.
TorqueWalkerParams velocity_walker_defaults();
/// The defaults for an actuation: TorqueWalkerParams{} or velocity_walker_defaults().
TorqueWalkerParams walker_defaults(WalkerActuation actuation);

/// One strike of the torque walker.
struct TorqueWalkerStrike {
  double time_s = 0;
  int side = 0;              ///< the foot that struck (0 left, 1 right)
  double step_length_m = 0;  ///< along the heading, ankle to ankle
  double step_width_m = 0;   ///< across it
  double step_across_m = 0;  ///< across it, signed: the struck ankle left of the other
  double target_length_m =
      std::numeric_limits<double>::quiet_NaN();  ///< the planned length; NaN: a free step
  /// The planned width (plan_steps' widths_m); NaN: the balance feedback's.
  double target_width_m = std::numeric_limits<double>::quiet_NaN();
  /// A planned step whose target the leg could not reach: it landed at the closest reachable
  /// point (paper §4.2).
  bool target_out_of_reach = false;
};

/// What the torque walker carries from one step to the next (a copyable aggregate).
struct TorqueWalkerState {
  // The command (set between steps).
  double speed_m_s = 1.0;  ///< m/s along the heading (0 once stopping)
  double heading_rate_rad_s = 0;
  // The state machine.
  int stance = 0;  ///< the stance foot (0 left, 1 right)
  int phase = 0;   ///< index into params().phases
  int strikes = 0;
  double phase_start_s = 0, start_s = 0;
  HeadingFrame heading;
  StrikeDetector strike;
  TorqueWalkerStrike last_strike;
  Eigen::Vector3d com_at_strike = Eigen::Vector3d::Zero();
  double ankle_height_m = 0;  ///< the ankles' height standing flat, measured at reset
  // Speed and drift regulation (rad).
  double lean_integral = 0, roll_integral = 0;
  double lean_step = 0;  ///< the proportional part (speed_step_gain_rad_per_m_s)
  // Base-polygon balance: the rule's step length and width for this swing (NaN: not moved).
  double rule_length_m = std::numeric_limits<double>::quiet_NaN();
  double rule_width_m = std::numeric_limits<double>::quiet_NaN();
  int rule_steps = 0;
  bool rule_bound = false;  ///< the rule's step has overridden the balance feedback this swing
  std::vector<Eigen::Vector2d> support, tolerance;  ///< the last evaluated polygons (world xy)
  // Constrained stepping.
  std::vector<double> plan, plan_width;  // lengths; widths (empty: the balance feedback's)
  int plan_next = 0;
  double swing_target_m = std::numeric_limits<double>::quiet_NaN();
  double swing_width_m = std::numeric_limits<double>::quiet_NaN();
  bool swing_out_of_reach = false;  ///< the current placed step's target is beyond the leg
  double free_step_s = 0;           ///< s, the last free step's time (plan_speed_gain)
  /// m/s, the walk's own speed for the catching step: the mean CoM speed of the last free step
  /// after the start, and how many such steps there have been.
  double walk_step_speed_m_s = 0;
  int walk_steps = 0;
  /// A counted step has come within speed_recovery_deadband_m_s of the command (since the start
  /// or the last command change): only then is a slow step a near stop (speed recovery).
  bool at_speed = false;
  /// m/s, the speed the plan asks now (NaN: no plan).
  double plan_speed_m_s = std::numeric_limits<double>::quiet_NaN();
  bool stopping = false, stopped = false;
  double stop_from_m_s = 0;  ///< the speed command when the stop was asked
  // The last IK solution of a placed step, for its rates.
  bool ik_valid = false;
  int ik_phase = -1;
  double ik_time_s = 0, ik_pitch = 0, ik_knee = 0, ik_pitch_rate = 0, ik_knee_rate = 0;
};

class TorqueWalker : public ControlDriver {
 public:
  /// For a rig with legs (thigh, shank, foot, optional toes; groups hip, knee, ankle, optional
  /// toe) and a lower back (a lumbar joint, or the paper's lower-body model's trunk:
  /// models::Rig::require_lower_back). Throws models::RigError if a part is missing,
  /// sim::InvalidArgument if the params are invalid. The rig must outlive the walker.
  TorqueWalker(const models::Rig& rig, TorqueWalkerParams params);

  /// Starts from the current state: left foot in stance, early swing of the right leg,
  /// heading from the pelvis yaw. Needs positions computed (mj_forward).
  void reset(const mjData& d);
  void set_heading_rate(double rad_s) { state_.heading_rate_rad_s = rad_s; }
  /// Commanded speed along the heading, m/s (> 0).
  void set_speed(double m_s) {
    if (m_s != state_.speed_m_s) state_.at_speed = false;
    state_.speed_m_s = m_s;
  }
  double speed_command() const { return state_.speed_m_s; }
  /// rad, the lean the speed regulation adds now (feed-forward + integral); `starting`: within
  /// start_time_s from standing (start_at_reference_speed).
  double speed_lean_rad(bool starting) const;
  /// Within start_time_s of the start from standing (the start's lean, start_at_reference_speed;
  /// the speed regulation counts steps only after it).
  bool in_start(double time_s) const { return time_s - state_.start_s < params_.start_time_s; }
  /// s, a time phase's length at the commanded speed (`starting`: as speed_lean_rad).
  double phase_duration_s(int phase, bool starting) const;
  /// Constrained stepping: the next steps' lengths, m, along the heading (ankle to ankle),
  /// from the swing that starts at the next strike; afterwards the steps are free again.
  /// `widths_m` (empty, or one per length): each step's width, m, ankle to ankle across the
  /// heading, positive with the swing foot on its own side (negative: a cross-over); without
  /// it the balance feedback places the foot across. Replaces any plan not yet walked. Throws
  /// sim::InvalidArgument for a length outside [0, 1.5] m or a width outside [-0.3, 0.8] m
  /// (naming its index), or a widths list of another size.
  void plan_steps(const std::vector<double>& lengths_m, const std::vector<double>& widths_m = {});
  /// The check plan_steps makes, without a walker (to refuse a plan before a run starts).
  static void validate_plan(const std::vector<double>& lengths_m,
                            const std::vector<double>& widths_m = {});
  /// Stopping back to standing: the speed command drops to 0 and the steps brake (the swing
  /// foot lands further ahead, stop_brake_rad_per_m_s) until the CoM is slower than
  /// stop_speed_m_s at a strike; then one planned step (as above) brings the feet side by
  /// side. stopped() is true from that strike on, and the walker no longer swaps legs: hand
  /// the character to the standing controller (ControlPipeline::set_driver(nullptr) with both
  /// feet in stance).
  void request_stop();
  bool stopping() const { return state_.stopping; }
  bool stopped() const { return state_.stopped; }
  /// Planned steps not yet begun.
  int planned_steps_left() const { return static_cast<int>(state_.plan.size()) - state_.plan_next; }
  /// The current swing's planned length (NaN for a free step).
  double swing_target_m() const { return state_.swing_target_m; }
  /// The current swing's planned width (NaN: free across).
  double swing_width_m() const { return state_.swing_width_m; }
  /// Base-polygon balance: whether the rule moves the current swing's strike, and how many
  /// steps it has moved since reset(). The last evaluated support and tolerance polygons
  /// (world xy, counter-clockwise; empty when not evaluated).
  bool base_polygon_rule_active() const { return state_.rule_bound; }
  int base_polygon_steps() const { return state_.rule_steps; }
  const std::vector<Eigen::Vector2d>& support_polygon() const { return state_.support; }
  const std::vector<Eigen::Vector2d>& tolerance_polygon() const { return state_.tolerance; }
  void drive(const ControlInput& in, ControlFrame* frame) override;
  /// Torques (default) or the velocity-based controllers; from the next drive() on.
  void set_actuation(WalkerActuation a) { actuation_ = a; }
  WalkerActuation actuation() const { return actuation_; }

  const TorqueWalkerParams& params() const { return params_; }
  /// Replaces the parameters from the next drive() on (the viewer's live edits); the current
  /// phase index is kept, clamped to the new list. Throws sim::InvalidArgument naming the field
  /// (the parameters are then unchanged). Allocates: not for the step loop.
  void set_params(const TorqueWalkerParams& params);
  int stance_side() const { return state_.stance; }
  /// The current phase's index in params().phases.
  int phase() const { return state_.phase; }
  int strike_count() const { return state_.strikes; }
  const TorqueWalkerStrike& last_strike() const { return state_.last_strike; }
  double heading_rad() const { return state_.heading.heading_rad(); }

  const TorqueWalkerState& state() const { return state_; }
  /// Takes over a state saved from this walker (rewind).
  void restore(const TorqueWalkerState& state) { state_ = state; }

 private:
  /// Sets and returns the PD torque of one hinge DOF (towards target at target_rate).
  double hinge_pd(ControlFrame* f, const mjModel& m, const mjData& d, int dof, double target,
                  double kp, double target_rate = 0, double feedforward = 0) const;
  /// The knee torque of stance_weight_support for leg `side` carrying `share` of it.
  double knee_weight_support(const mjModel& m, const mjData& d, int side, double share) const;
  void hip_torque(ControlFrame* f, const mjData& d, int side,
                  const Eigen::Vector3d& torque_W) const;
  /// The stance hip's share of its roll and yaw torque (stance_hip_load_share): the stance foot's
  /// share of both feet's vertical ground force in the last step, 1 in the air.
  double stance_hip_share(const mjModel& m, const StepReport& last) const;
  /// The stop's closing step (the planned step of length 0 that brings the feet side by side).
  bool closing_step() const { return state_.stopping && state_.swing_target_m == 0.0; }
  /// The phase machine: time phases in order, then the last one until the swing foot strikes.
  void advance_phases(const mjModel& m, const mjData& d, const sim::CenterOfMass& com);
  /// At a strike: step records, speed and drift integrals, the next planned step, the stop.
  void on_strike(const mjData& d, const sim::CenterOfMass& com, int swing);
  /// Every joint but the legs holds the standing pose; returns the lower back's torque on the
  /// upper body (world), whose reaction the stance hip takes (torque actuation; zero with
  /// velocity actuation, whose whole-body solve carries the reactions).
  Eigen::Vector3d hold_upper_body(ControlFrame* f, const mjModel& m, const mjData& d) const;
  /// Constrained stepping: the IK triangle for the planned step's ankle target (and its rates).
  LegTriangle placed_step_ik(const mjData& d, const TorqueWalkerPhase& ph);
  /// Knees, ankles (the swing sole level) and toes.
  void leg_joints(ControlFrame* f, const mjModel& m, const mjData& d, const TorqueWalkerPhase& ph,
                  bool placed, const LegTriangle& ik) const;
  /// The swing thigh's goal pitch and roll (balance feedback, IK, base-polygon rule), heading
  /// frame.
  Eigen::Vector2d swing_thigh_angles(const mjData& d, const TorqueWalkerPhase& ph, bool placed,
                                     const LegTriangle& ik, const Eigen::Vector3d& rel,
                                     const Eigen::Vector3d& vel);
  /// Paper §4.3 during a swing: accumulates the rule's step for this swing (gait core).
  void apply_base_polygon_rule(const mjModel& m, const mjData& d, const Eigen::Vector3d& com_W,
                               const Eigen::Vector3d& com_velocity_H);
  /// The non-leg groups' PD gains from the params (trunk, arms, distal).
  void set_gains();
  /// Velocity actuation: hinge group `group` (its first DOF) to `angle` with the walker's
  /// optimal time, or a spring of gain `kp` about it when `spring`.
  void hinge_target(ControlFrame* f, const mjData& d, int group, double angle, double kp,
                    bool spring) const;
  /// Velocity actuation of the hips: the swing thigh to `q_thigh_goal` (world), the stance hip
  /// holding the pelvis at `q_pelvis_goal` (world); `swing_down`: the trailing foot is on the
  /// floor (double support), its hip a spring.
  void hip_targets(ControlFrame* f, const mjModel& m, const mjData& d,
                   const Eigen::Quaterniond& q_thigh_goal, const Eigen::Quaterniond& q_pelvis_goal,
                   bool swing_down) const;

  TorqueWalkerParams params_;
  TorqueWalkerState state_;
  WalkerActuation actuation_ = WalkerActuation::kTorque;
  const models::Rig* rig_;
  double gain_scale_ = 1;  // body mass / 80 kg
  double body_mass_kg_ = 0;
  int lumbar_ = -1;
  std::vector<double> kp_;  // per group, the PD gain of the non-leg groups
  std::vector<bool> leg_;   // per group: hip, knee, ankle or toe
  SupportPolygons polygons_;
};

}  // namespace biodyn::controllers
