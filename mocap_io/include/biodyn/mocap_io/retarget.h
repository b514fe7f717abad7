#pragma once
/// Retargeting a BVH motion to a generated character (issue 5): the BVH's joints are mapped to
/// the character's keypoints (joint centres: body origins, plus the ends of head, hands, toes)
/// by a joint map given as data; the keypoint targets are rebuilt on the character's own
/// segment lengths (a bone keeps the BVH's direction, not its length); the root moves as the
/// capture's scaled by the leg-length ratio; foot contacts are detected on the BVH and the
/// stance foot's sole is pinned to the floor (z = 0) where it landed; marker IK (marker_ik.h)
/// solves every frame against those targets. Outputs: the character's qpos (motion_csv.h), a
/// BVH of the character (its own hierarchy) and statistics measured on the result (MuJoCo
/// kinematics of the output qpos, never the targets).
///
/// Conventions (see mocap_io/README.md, "Retargeting"):
/// - World: biodyn's (z up, metres); the BVH is read through BvhUnits. The capture's heading
///   and position are kept (horizontal motion scaled about the world origin) unless
///   RetargetOptions::align_start moves the start to the origin facing +x.
/// - Scale s = (thigh + shank of the character) / (hip-knee + knee-ankle of the BVH), the mean
///   of both sides. Root horizontal motion is multiplied by s; root height is s times the
///   BVH's height above its ankles' stance level, plus the character's ankle height.
/// - Directions: a keypoint target is its parent keypoint's target plus the character's bone
///   length along the BVH bone's direction ("direction" keypoints), or the parent's rest offset
///   on the character turned by the BVH joint's rotation from its rest pose ("rigid"
///   keypoints: hips and lumbar on the pelvis, clavicles and shoulders on the thorax).
/// - Feet: the foot and toes orientations are the BVH ankle's and toe joint's rotations with a
///   constant correction measured on the capture's own flat-foot frames (both heel and ball in
///   contact), so a rig whose rest pose has the foot pitched or the legs splayed still lands
///   the character's sole flat.

#include <Eigen/Core>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "biodyn/mocap_io/bvh.h"
#include "biodyn/mocap_io/marker_data.h"
#include "biodyn/mocap_io/marker_ik.h"
#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/models/character.h"

namespace biodyn::mocap_io {

// ---------------------------------------------------------------------------------------------
// Joint maps (data)
// ---------------------------------------------------------------------------------------------

/// How one character keypoint is found in a BVH.
struct KeypointMapping {
  /// Character keypoint (keypoint_names()): a segment name (its origin, the joint centre that
  /// connects it to its parent) or "<segment>_end" (head top, hand tip, toe tip, trunk top).
  std::string keypoint;
  /// BVH joints whose mean world position is the keypoint's position in the capture ("End
  /// Site"s are "<parent>_end"). A name also matches a BVH joint carrying a namespace prefix
  /// ("mixamorig:Hips" matches "Hips").
  std::vector<std::string> joints;
  /// BVH joint whose rotation from its rest pose turns this keypoint's segment: used for the
  /// rigid children of this keypoint, and for the feet. Empty: joints[0].
  std::string frame;
  /// true: placed from the parent keypoint by the character's rest offset turned by the
  /// parent's frame; false: the parent's target plus the character's bone length along the
  /// BVH bone (parent -> this keypoint).
  bool rigid = false;
  double weight = 1.0;    ///< IK weight (>= 0)
  bool optional = false;  ///< true: left out (not an error) when the BVH lacks a joint

  /// frame, or joints[0] when frame is empty.
  const std::string& frame_joint() const { return frame.empty() ? joints.front() : frame; }
};

/// A joint map: character keypoints -> BVH joints, plus the rig's usual units.
///
/// JSON:
///   {"name": "cmu", "description": "...",
///    "units": {"metres_per_unit": 0.056444, "up": "y"},
///    "keypoints": {
///      "pelvis": {"joints": ["LeftHip", "RightHip"], "frame": "Hips"},
///      "thigh_l": {"joints": "LeftHip", "rigid": true},
///      "shank_l": "LeftKnee",
///      "hand_l_end": {"joints": "LFingers", "weight": 0.5, "optional": true}}}
/// A keypoint given as a string is {"joints": that string}. "pelvis" is required (it carries
/// the root), and so are thigh, shank, foot and toes of both sides (they carry the contacts).
struct JointMap {
  std::string name;
  std::string description;
  std::optional<BvhUnits> units;           ///< the rig's usual units, if the map states them
  std::vector<KeypointMapping> keypoints;  ///< sorted by keypoint name

  /// The mapping of `keypoint`, or nullptr.
  const KeypointMapping* find(const std::string& keypoint) const;
};

/// Every keypoint a joint map may name: the segments of both detail levels and the ends
/// head_end, hand_l_end, hand_r_end, toes_l_end, toes_r_end, trunk_end.
std::vector<std::string> keypoint_names();

/// Parses a joint map; `source` names the file in errors. Throws sim::InvalidArgument naming
/// the source, the field (keypoints.shank_l.joints, ...), the rule and the value: malformed
/// JSON, an unknown field, an unknown keypoint (listing the known ones), no joints, a negative
/// weight, a required keypoint missing, units not positive or an up axis other than y/z.
JointMap parse_joint_map(const std::string& json_text, const std::string& source);
/// parse_joint_map of a file (sim::InvalidArgument if it cannot be read).
JointMap read_joint_map(const std::string& path);

/// Names of the built-in maps: "cmu" (CMU database BVH conversions), "mixamo" (Mixamo and
/// similar rigs: Hips, LeftUpLeg, LeftLeg, LeftFoot, LeftToeBase, Spine..., LeftArm...) and
/// "biodyn" (the character BVHs retarget_bvh writes).
std::vector<std::string> builtin_joint_map_names();
/// A built-in map by name; throws sim::InvalidArgument listing the names otherwise.
JointMap builtin_joint_map(const std::string& name);

/// Index of the BVH joint `name` (exact, else the only joint named "<prefix>:<name>"), or -1.
int find_bvh_joint(const BvhMotion& motion, const std::string& name);

/// `map` with every BVH joint resolved against `motion`: optional keypoints with a missing
/// joint are dropped. Throws sim::InvalidArgument naming `bvh_source`, the map, the keypoint
/// and the joint for a required keypoint whose joint the BVH lacks.
JointMap resolve_joint_map(const JointMap& map, const BvhMotion& motion,
                           const std::string& bvh_source);

/// The first built-in map (builtin_joint_map_names order) whose required joints `motion` has,
/// or nullopt; `tried` (optional) gets each refusal, one per line, for the caller's message.
std::optional<JointMap> first_fitting_builtin_map(const BvhMotion& motion,
                                                  const std::string& bvh_source,
                                                  std::string* tried = nullptr);

// ---------------------------------------------------------------------------------------------
// Retargeting
// ---------------------------------------------------------------------------------------------

/// Foot-contact detection on the BVH. A foot has two contact points: the heel (watched through
/// the joint mapped to foot_<side>, the ankle) and the ball (the joint mapped to toes_<side>,
/// the MTP joint). A point is in contact while it is near its stance level and nearly still.
/// Lengths are in the capture's metres (after BvhUnits).
struct ContactOptions {
  /// m above the point's stance level to enter / stay in contact. A walking heel rises ~1 cm
  /// over loading response while still on the floor, and toe clearance in swing is ~1.5-2 cm
  /// above the stance height (Winter 1992, "Foot trajectory in human gait"): 2 cm in, 3 cm out.
  double enter_height_m = 0.02;
  double exit_height_m = 0.03;
  /// m/s horizontal speed to enter / stay in contact. A planted point moves < 0.1 m/s (marker
  /// noise and skin motion at 120 Hz); the swing foot exceeds 1 m/s within ~50 ms of lift-off
  /// (Winter 2009, Fig. 3.11 heel and toe velocities); the ankle moves ~0.3 m/s while the foot
  /// rolls down about the heel.
  double enter_speed_m_s = 0.3;
  double exit_speed_m_s = 0.5;
  /// s: contacts shorter than this are dropped, gaps shorter than this are bridged (a few
  /// frames of noise must not split or make a step; a walking stance lasts ~0.6 s).
  double min_duration_s = 0.05;
  /// s: speeds are central differences over +-this (smooths marker noise; one frame at 60 Hz).
  double speed_window_s = 1.0 / 60.0;

  /// Throws sim::InvalidArgument naming the field and the value.
  void validate() const;
};

struct RetargetOptions {
  /// Units and up axis of the BVH; unset: the joint map's units, else BvhUnits{} (cm, y up).
  std::optional<BvhUnits> units;
  /// false: keep the capture's heading and position (horizontal motion scaled about the
  /// world origin). true: start at the origin (pelvis above it) facing +x.
  bool align_start = false;
  ContactOptions contacts;
  /// IK weight of each sole point (5 per foot: heel medial/lateral, ball medial/lateral, toe
  /// tip) in and near contact; keypoints weigh their map weight (1). A planted sole must not
  /// slide or sink, so it dominates the joint centres.
  double contact_weight = 100.0;
  /// IK weight of the sole points in mid-swing (faded to contact_weight over blend_s before a
  /// touch-down and after a lift-off). The ankle has no axial DOF: a heavy swing foot would
  /// twist the leg to match the capture's foot orientation exactly, so it weighs as a keypoint.
  double swing_weight = 1.0;
  /// s, the correction that pins a stance foot is faded in before touch-down and out after
  /// lift-off over at most this long (less when the swing is shorter), so the swing foot
  /// does not jump.
  double blend_s = 0.15;
  /// m: a planted sole point the IK cannot hold within this distance of its pin (the capture's
  /// pose is out of the character's reach: e.g. a crouched stance needing more ankle
  /// dorsiflexion than the character's 20 degrees) is released from that frame on: the heel (or
  /// the toes) lifts early, as a person with that range would, instead of sliding.
  double release_error_m = 0.004;
  MarkerIkOptions ik;
  /// Units and axes of the character BVH written (default: centimetres, y up, the most common
  /// convention of BVH viewers).
  BvhUnits output_units = BvhUnits{0.01, UpAxis::kY};
  /// Names the input in the output's comments and in errors (e.g. the BVH's path).
  std::string source = "<bvh>";

  /// Throws sim::InvalidArgument naming the field and the value.
  void validate() const;
};

/// One contact interval of one sole point of one foot (frames inclusive).
struct FootContact {
  char side = 'l';  ///< 'l' or 'r'
  /// "heel_med", "heel_lat" (the heel's medial and lateral bottom corners), "ball_med",
  /// "ball_lat" (under the MTP joint) or "tip" (the toe tip), all on the sole.
  std::string point;
  int first_frame = 0;
  int last_frame = 0;
};

/// One stance of one foot (its heel and ball contacts that overlap or touch) and what the
/// retargeted character did during it.
struct StanceStep {
  char side = 'l';
  int first_frame = 0;
  int last_frame = 0;
  /// m: the largest horizontal displacement of a sole point of the character (MuJoCo
  /// kinematics of the output) from where it stood when its contact began, over that contact
  /// (heel points during the heel contact, ball and tip during the ball contact).
  double slide_m = 0.0;
  int slide_frame = -1;  ///< the frame of slide_m (-1: no solved frame)
  /// The limited joints of that leg held on a limit at slide_frame: a step that slides with
  /// its leg on a limit asks for more range of motion than the character has (e.g. a kneel on
  /// tucked toes beyond the toes' 70 degrees); empty otherwise.
  std::vector<std::string> joints_at_limit;
  /// m: the largest |z| of those sole points over their contacts (how far off the floor the
  /// planted sole was).
  double height_error_m = 0.0;
};

/// m: the deepest a retargeted body may sink into the floor; the floor guards hold it (CMU
/// 131_01 on 1.5-2.0 m bodies: <= 1 mm). feet.png draws it; the tests assert it.
inline constexpr double kRetargetPenetrationBound_m = 0.001;

/// Statistics measured on the output (MuJoCo kinematics of the output qpos).
struct RetargetStats {
  int frames = 0;
  int unsolved_frames = 0;        ///< frames IK could not solve (their qpos rows are NaN)
  double scale = 1.0;             ///< character leg / BVH leg
  double bvh_leg_m = 0.0;         ///< m, hip-knee + knee-ankle of the BVH (mean of the sides)
  double character_leg_m = 0.0;   ///< m, thigh + shank of the character
  double keypoint_rms_m = 0.0;    ///< m, RMS keypoint site - target over all keypoints and frames
  double keypoint_max_m = 0.0;    ///< m, the largest keypoint error
  std::string keypoint_max_name;  ///< the keypoint with keypoint_max_m
  int keypoint_max_frame = -1;
  double max_slide_m = 0.0;  ///< m, the largest StanceStep::slide_m
  /// m (>= 0): depth of the lowest geom point below the floor over the whole motion (0 when
  /// nothing goes below z = 0).
  double max_penetration_m = 0.0;
  int penetration_frame = -1;
  std::string penetration_geom;
  /// m, horizontal distance of the pelvis from the first to the last frame: the BVH's pelvis
  /// keypoint and the character's pelvis.
  double bvh_travel_m = 0.0;
  double character_travel_m = 0.0;
  /// Planted sole points released because the IK could not hold them (release_error_m).
  int released_contacts = 0;
  double mean_ik_iterations = 0.0;  ///< LM iterations per solve (re-solves included)
  double ik_seconds = 0.0;          ///< s, wall time of the per-frame IK solves
  double total_seconds = 0.0;       ///< s, wall time of retarget_bvh
};

struct RetargetResult {
  /// The character solved for: the input spec with the retargeting sites as its markers
  /// (marker_kp_<keypoint>, marker_sole_<point>_<side>). The qpos layout does not depend on
  /// the markers, so the motion also plays on generate_character of the input spec.
  models::CharacterSpec spec;
  Motion motion;  ///< the character's qpos per BVH frame (times from the BVH's frame time)
  BvhMotion bvh;  ///< the character's own hierarchy (character_bvh), per RetargetOptions
  /// The IK targets (labels kp_<keypoint>, sole_<point>_<side>), m, world; for inspection.
  MarkerData targets;
  std::vector<FootContact> contacts;  ///< detected on the BVH, by side, point, then time
  std::vector<StanceStep> steps;      ///< by first frame
  RetargetStats stats;
};

/// Retargets `motion` to the character `spec` (its markers are replaced by the retargeting
/// sites) through `map`. `progress`, if given, is called with the fraction of frames solved.
/// Throws sim::InvalidArgument for bad options, a map the BVH does not fit
/// (resolve_joint_map), a keypoint the character lacks that the map requires, or a capture
/// whose legs have zero length.
RetargetResult retarget_bvh(const BvhMotion& motion, const JointMap& map,
                            const models::CharacterSpec& spec, const RetargetOptions& options = {},
                            const std::function<void(double fraction)>& progress = {});

/// m, world: the far end of segment `s` in the standing pose (toes point forward, hands hang
/// down, head and the gait trunk end at their tops): where the "<segment>_end" keypoints and the
/// character BVH's End Sites sit.
Eigen::Vector3d segment_end_W(const models::Segment& s);

/// A BVH of the character `c` playing `qpos` (frames x model.nq, model = to_mjcf(c) compiled;
/// NaN rows are written as the previous solved frame, or the standing pose): one joint per
/// segment named after it, at the segment's origin (the root "pelvis" with 6 channels, every
/// other segment 3 rotation channels whatever its DOFs), an End Site at the far end of each
/// leaf segment (head, hands, toes: "<segment>_end"). Forward kinematics of the result with
/// `units` gives MuJoCo's body positions. Channel orders avoid gimbal lock in the usual ranges:
/// the root "Yrotation Xrotation Zrotation" with y up (heading first), the others "Zrotation
/// Yrotation Xrotation" (twist about the vertical in the middle); with z up (file axes = world
/// axes) the same roles give "Zrotation Yrotation Xrotation" and "Xrotation Zrotation Yrotation".
/// Throws sim::InvalidArgument if qpos has the wrong width or model is not c's.
BvhMotion character_bvh(const models::Character& c, const mjModel& model,
                        const Eigen::MatrixXd& qpos, double frame_time_s,
                        const BvhUnits& units = BvhUnits{0.01, UpAxis::kY});

/// The character BVH (character_bvh) of a qpos motion on its own body, the one its "# body:"
/// header names (mocap ik and retarget write it): what carries a motion from marker IK or an
/// earlier retarget through retarget_bvh (the "biodyn" map) onto another body, or onto the
/// same body with its stance feet planted flat and still. Unsolved frames (NaN rows) are left
/// out: the longest solved run is used (its first frame at time 0). `source` names the file in
/// errors. Throws sim::InvalidArgument for a motion without a body header, of the wrong width for
/// its body, or with fewer than 2 solved frames in a row.
BvhMotion motion_bvh(const Motion& motion, const std::string& source);

/// The BVH file at `path` retargeted onto `character` with the first built-in joint map that
/// fits it (default options). Throws sim::InvalidArgument naming the file when it cannot be
/// read or no built-in map fits (listing what was tried).
Motion retarget_bvh_file(const std::string& path, const models::CharacterSpec& character);

}  // namespace biodyn::mocap_io
