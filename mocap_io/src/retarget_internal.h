#pragma once
/// Private to mocap_io: the stages of retarget_bvh (retarget.h) and what they share. retarget.cc
/// runs them in order: the capture read onto the character's proportions (retarget_targets.cc),
/// the sole points' contacts and pins (retarget_contacts.cc), the IK sites and the IK pass
/// (retarget_ik.cc), then the result measured on MuJoCo's kinematics of the output (retarget.cc).

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cstddef>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "biodyn/mocap_io/retarget.h"
#include "biodyn/sim/model.h"

namespace biodyn::mocap_io::retarget_internal {

using Eigen::Matrix3d;
using Eigen::Vector3d;

constexpr int kSoles = 5;  ///< sole points per foot
inline constexpr const char* kSides[] = {"l", "r"};

inline double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

inline Matrix3d rot_z(double angle) {
  return Eigen::AngleAxisd(angle, Vector3d::UnitZ()).toRotationMatrix();
}
inline Matrix3d rot_y(double angle) {
  return Eigen::AngleAxisd(angle, Vector3d::UnitY()).toRotationMatrix();
}
inline Matrix3d rot_x(double angle) {
  return Eigen::AngleAxisd(angle, Vector3d::UnitX()).toRotationMatrix();
}

inline double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

/// A frame, point or side index as a container index.
inline size_t at(int i) { return static_cast<size_t>(i); }

// ----------------------------------------------------------------------------------------------
// The capture and the character's keypoints
// ----------------------------------------------------------------------------------------------

/// One mapped keypoint of the character, with where it sits and how it is found in the BVH.
struct Keypoint {
  std::string name;
  KeypointMapping map;
  int parent = -1;                  ///< index into the keypoint list; -1 for the pelvis
  Vector3d o_W = Vector3d::Zero();  ///< m, position on the standing character
  std::string site_segment;         ///< segment carrying its IK site
  std::vector<int> bvh;             ///< BVH joints (mean position)
  int frame_joint = -1;             ///< BVH joint whose rotation orients it
};

/// The BVH's forward kinematics at every frame and in its rest pose (all channels zero).
struct Capture {
  std::vector<BvhPose> poses;
  BvhPose rest;

  Vector3d position(const Keypoint& k, int f) const {
    Vector3d p = Vector3d::Zero();
    for (int j : k.bvh) p += poses[at(f)].positions_W.col(j);
    return p / static_cast<double>(k.bvh.size());
  }
  Vector3d rest_position(const Keypoint& k) const {
    Vector3d p = Vector3d::Zero();
    for (int j : k.bvh) p += rest.positions_W.col(j);
    return p / static_cast<double>(k.bvh.size());
  }
  /// R_WJ(f) R_WJ(rest)^T of joint j: its rotation from the rest pose, in the world.
  Matrix3d from_rest(int j, int f) const {
    return poses[at(f)].rotations_W[at(j)] * rest.rotations_W[at(j)].transpose();
  }
};

/// What every stage reads: the capture, the character (its markers left out: they move
/// nothing) and its mapped keypoints, and the names errors give.
struct RetargetInput {
  std::string source;    ///< names the input in errors (RetargetOptions::source)
  std::string map_name;  ///< the joint map's name, for errors
  int frames = 0;
  double dt = 0.0;  ///< s, the BVH's frame time
  models::Character plain;
  std::vector<Keypoint> kps;  ///< parents before children (character_keypoints)
  Capture cap;

  /// The keypoint `name`. Throws sim::InvalidArgument if the map places none on the character.
  const Keypoint& keypoint(const std::string& name) const;
};

// ----------------------------------------------------------------------------------------------
// Contact detection and the feet (retarget_contacts.cc)
// ----------------------------------------------------------------------------------------------

using Interval = std::pair<int, int>;  // first, last frame (inclusive)

/// Contact intervals of one tracked point (world frame, m): near its stance level (`level`
/// receives it: the median height over the frames where the point is slow) and nearly still,
/// with hysteresis; short gaps bridged and short contacts dropped.
std::vector<Interval> detect_point(const std::vector<Vector3d>& p, double dt,
                                   const ContactOptions& o, double* level);

/// Per frame (`frames` of them): whether it lies in one of `intervals`.
std::vector<bool> flags(const std::vector<Interval>& intervals, int frames);

/// The sole points of a foot: the bottom corners of the heel (foot body), under the MTP joint
/// (toes body) and the toe tip (toes body), in their body frames.
struct Sole {
  static constexpr const char* kNames[kSoles] = {"heel_med", "heel_lat", "ball_med", "ball_lat",
                                                 "tip"};
  std::array<Vector3d, kSoles> point_B;
  static bool on_toes(int p) { return p >= 2; }
};

/// The sole points of the character's foot on `side` ("l" or "r").
Sole sole_of(const models::Character& c, const std::string& side);

/// A rigid correction of a foot's free targets: a turn about the vertical through the free
/// ankle, then a translation. Planted points pin the foot; the correction carries the rest of
/// it (and the ankle) along, so points landing later agree with the foot's shape.
struct FootCorrection {
  double yaw = 0.0;               ///< rad about +z
  Vector3d t = Vector3d::Zero();  ///< m
  Vector3d apply(const Vector3d& free, const Vector3d& ankle) const {
    return ankle + rot_z(yaw) * (free - ankle) + t;
  }
  FootCorrection scaled(double w) const { return {w * yaw, w * t}; }
  FootCorrection plus(const FootCorrection& o) const { return {yaw + o.yaw, t + o.t}; }
};

using SolePoints = std::array<Vector3d, kSoles>;

/// One foot over the clip: its free motion, contacts, plants and corrections, and how its
/// targets are composed from them.
struct FootTrack {
  Sole sole;
  Vector3d ankle_to_mtp_W = Vector3d::Zero();  ///< m, on the standing character
  std::vector<Matrix3d> r_free;                ///< free foot orientation (level roll), per frame
  std::vector<double> toe;       ///< rad, toes turned about the foot's y axis (+: down)
  std::vector<Vector3d> ankle;   ///< m, free ankle target
  std::vector<SolePoints> free;  ///< m, free sole points (level roll)
  std::array<std::vector<Interval>, kSoles> contacts;
  std::vector<std::array<bool, kSoles>> planted;
  std::vector<SolePoints> plant;  ///< m, where planted
  std::vector<FootCorrection> correction;
  std::vector<SolePoints> extra;  ///< m, each point's faded mismatch near its contacts
  std::array<std::vector<bool>, kSoles> released;  ///< per contact: ended by a release
  std::vector<bool> stance;                        ///< any point planted
  std::vector<double> roll_weight;  ///< 1 in mid-swing (roll free), 0 near and in stance
  /// Per point, 1 in contact fading to 0 over `blend` frames before and after (a released
  /// contact ends at once): how much of the contact weight the point carries.
  std::vector<std::array<double, kSoles>> contact_share;

  int frames() const { return static_cast<int>(ankle.size()); }

  /// Free sole points at frame f with the foot rolled by `roll` (rad) about its long axis.
  SolePoints free_points(int f, double roll) const;

  /// Targets at frame f of the sole points and the ankle: planted points at their plants, the
  /// others corrected, never below the floor (the free points and the ankle lifted together).
  void compose(int f, double roll, SolePoints* sole_target, Vector3d* ankle_target) const;
};

/// Detects the contacts of the foot's sole points on their free trajectories (the capture's
/// foot motion on the character's sole), then pins them (plant).
void plan_contacts(const ContactOptions& o, double dt, int blend, FootTrack* t);

/// Pins the foot's contacts (plants and the correction fitted to them), fades the correction
/// off the stance, and fades each point's own mismatch in before its touch-down and out after
/// its lift-off.
void plant(FootTrack* t, int blend);

/// Ends point p's contact at frame f (drops it if it starts there) and plans the foot again;
/// frames before f keep their targets.
void release(FootTrack* t, int p, int f, int blend);

// ----------------------------------------------------------------------------------------------
// The capture on the character's proportions (retarget_targets.cc)
// ----------------------------------------------------------------------------------------------

/// The capture read onto the character: the plain character, its keypoints and the BVH's
/// kinematics. Throws sim::InvalidArgument for no frames, a frame time out of range or joint
/// positions not finite or beyond kMaxCaptureExtent_m.
RetargetInput read_input(const BvhMotion& motion, const JointMap& map, const JointMap& resolved,
                         const models::CharacterSpec& spec, const BvhUnits& units,
                         const std::string& source);

/// The capture's legs against the character's, and the BVH's heel and ball contacts.
struct LegScale {
  double bvh_leg_m = 0.0;          ///< m, hip-knee + knee-ankle of the BVH (mean of the sides)
  double character_leg_m = 0.0;    ///< m, thigh + shank of the character (mean of the sides)
  double character_ankle_m = 0.0;  ///< m, height of the character's ankles standing
  double bvh_ankle_level_m = 0.0;  ///< m, the BVH ankles' stance level (mean of the sides)
  double scale = 0.0;              ///< character_leg_m / bvh_leg_m
  /// Per side: contacts of the BVH's ankle (heel) and MTP (ball) joints.
  std::array<std::vector<Interval>, 2> heel, ball;
};

/// Scale by leg length; the vertical scales about the ankles' stance level. Throws
/// sim::InvalidArgument for a leg keypoint the map does not place, two leg keypoints at one
/// place in the rest pose, or legs of zero length.
LegScale measure_legs(const RetargetInput& in, const ContactOptions& contacts);

/// Where the capture goes in the world: its facing turned to the character's and, with
/// RetargetOptions::align_start, its start moved to the origin facing +x.
struct Placement {
  Matrix3d r_face = Matrix3d::Identity();   ///< the BVH's rest facing onto the character's (+x)
  Matrix3d r_align = Matrix3d::Identity();  ///< turn of the start (align_start)
  Vector3d t_align = Vector3d::Zero();      ///< m, shift of the start (align_start)
  const Keypoint* pelvis = nullptr;         ///< into RetargetInput::kps
  double scale = 1.0;
  double bvh_ankle_level_m = 0.0;
  double character_ankle_m = 0.0;

  /// m, the root keypoint at frame f scaled onto the character, before the alignment.
  Vector3d root_position(const Capture& cap, int f) const {
    const Vector3d b = cap.position(*pelvis, f);
    return Vector3d(scale * b.x(), scale * b.y(),
                    scale * (b.z() - bvh_ankle_level_m) + character_ankle_m);
  }
};

/// The capture's facing and, if `align_start`, the alignment of its start. Throws
/// sim::InvalidArgument if the map places no pelvis or thigh keypoints.
Placement place_capture(const RetargetInput& in, const LegScale& legs, bool align_start);

/// One foot's keypoints and what "flat" is on the capture.
struct FootCalibration {
  int ankle = -1, mtp = -1;     ///< keypoints foot_<side> and toes_<side> (into kps)
  int tip = -1;                 ///< keypoint toes_<side>_end, -1 when not mapped
  double flat_pitch = 0.0;      ///< rad, pitch of the ankle -> MTP bone on a flat foot
  double flat_toe_pitch = 0.0;  ///< rad, the toe bone's angle on it (+: down)
  Vector3d flat_lateral_A = Vector3d::Zero();  ///< unit, level axis across it, ankle joint frame
};

/// The foot on side s (0 left, 1 right) measured on the capture's own flat-foot frames (both
/// heel and ball in contact; the rest pose if there are too few). Throws sim::InvalidArgument
/// if the map places no foot or toes keypoint there.
FootCalibration calibrate_foot(const RetargetInput& in, const LegScale& legs, int s);

/// A foot track for side s with its sole and room for every frame's free motion.
FootTrack start_foot_track(const RetargetInput& in, const FootCalibration& foot, int s);

/// Free targets: each keypoint's (3 x keypoints per frame; the toes' columns unset: the sole
/// points stand in for them), and each foot's free motion written into `feet`.
std::vector<Eigen::Matrix3Xd> free_targets(const RetargetInput& in, const Placement& placement,
                                           const std::array<FootCalibration, 2>& calibration,
                                           std::array<FootTrack, 2>* feet);

// ----------------------------------------------------------------------------------------------
// The IK (retarget_ik.cc)
// ----------------------------------------------------------------------------------------------

/// A floor guard: a site kept at or above `clearance_m` over the floor.
struct Guard {
  int label = 0;
  double clearance_m = 0.0;
};

/// The IK's sites on the character (its markers) in label order: the keypoints (but the toes),
/// then kSoles sole points per foot, then the floor guards.
struct IkSites {
  std::vector<std::string> labels;  ///< kp_<keypoint>, sole_<point>_<side>, guard_<...>_<side>
  std::vector<double> weights;      ///< IK weight per label
  std::vector<int> label_kp;        ///< keypoint (into kps) of each keypoint label
  int n_kp = 0;                     ///< keypoint labels
  std::array<int, 2> ankle_kp{};    ///< each foot's ankle keypoint (its target is the foot's)
  std::vector<Guard> guards;
};

/// Adds the IK's sites to `spec`'s markers: the keypoints, the sole points and the floor guards.
IkSites add_ik_sites(const RetargetInput& in, const std::array<FootTrack, 2>& feet,
                     const std::array<FootCalibration, 2>& calibration, double contact_weight,
                     models::CharacterSpec* spec);

/// The IK targets as far as they are known before the IK (the swing feet's roll is set during
/// it): keypoints and feet; guards untargeted (NaN).
MarkerData initial_targets(const std::vector<Eigen::Matrix3Xd>& kp_target,
                           const std::array<FootTrack, 2>& feet, const IkSites& sites, double dt);

/// The IK pass's output.
struct IkSolution {
  Eigen::MatrixXd qpos;  ///< frames x nq; NaN rows for unsolved frames
  long iterations = 0;   ///< LM iterations over every solve
};

/// IK, frame by frame, warm-started, against `targets` (whose feet and guard rows it sets);
/// releases planted points it cannot hold (so `feet` is planned again) and weighs the sites
/// through `sites`. Counts unsolved frames and released contacts into `stats`; `data` holds
/// the kinematics of the last solve.
IkSolution solve_ik(const sim::Model& model, const std::vector<int>& site_of_label,
                    const RetargetOptions& options, int blend, IkSites* sites,
                    std::array<FootTrack, 2>* feet, MarkerData* targets, sim::Data* data,
                    RetargetStats* stats, const std::function<void(double)>& progress);

}  // namespace biodyn::mocap_io::retarget_internal
