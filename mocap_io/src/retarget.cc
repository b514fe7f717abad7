// Retargeting a BVH to a generated character (retarget.h). Stages: sample the capture; build
// free targets on the character's proportions (keypoints and sole points); detect the sole
// points' contacts and pin them; solve marker IK frame by frame; measure the result with
// MuJoCo's kinematics of the output.
#include "biodyn/mocap_io/retarget.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>

#include "biodyn/models/mjcf.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/units.h"

namespace biodyn::mocap_io {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using sim::InvalidArgument;

/// m: a BVH bone shorter than this has no direction (two keypoints on one joint, e.g. CMU's
/// Chest2 and lowerneck); the keypoint is then placed rigidly.
constexpr double kMinBoneLength_m = 1e-6;
/// Flat-foot frames (heel and ball joints in contact) needed to measure what "flat" is on the
/// capture itself; with fewer, the BVH's rest pose is taken as flat. 5 frames is 42 ms at
/// 120 Hz: enough to average marker noise, far less than one stance (~0.6 s).
constexpr int kMinFlatFrames = 5;
/// Below this fraction of its length in the horizontal (a foot bone within ~11 degrees of
/// vertical) the axis across the foot is the capture's own, blended to level by twice that
/// (~23 degrees): a level axis across a vertical bone is undefined.
constexpr double kSteepFootSin = 0.2;
/// The capture's lateral axis of the foot tells which side is left when it is within 60 degrees
/// of the level axis (or of its opposite).
constexpr double kClearSideCos = 0.5;
/// m^2: planted sole points spread less than this (about 2 cm RMS from their mean) do not fix
/// the foot's yaw; it is held from the previous frame.
constexpr double kMinYawSpread_m2 = 0.02 * 0.02;
/// A roll-weight below this counts as zero when the swing roll is rescaled frame to frame.
constexpr double kMinRollWeight = 1e-3;
constexpr int kSoles = 5;  ///< sole points per foot
/// s: frame times accepted (10 kHz to one frame per 10 s); windows counted in frames stay in
/// int range.
constexpr double kMinFrameTime_s = 1e-4;
constexpr double kMaxFrameTime_s = 10.0;
/// m: a capture reaching further from the origin has the wrong units (no lab is 10 km wide);
/// squared lengths of such values would overflow.
constexpr double kMaxCaptureExtent_m = 1e4;
/// IK solves per frame at most: the first, then one per released contact or new floor guard.
constexpr int kMaxSolvesPerFrame = 40;
/// An active floor guard weighs this many times a planted point. Heavier guards fight the pins
/// (measured on the CMU clip: 3x and 10x raise the worst stance slide from 2.1 to 2.7 cm);
/// what they lack is made up by aiming them higher instead (see the guard loop).
constexpr double kGuardWeightFactor = 1.0;
/// m: a floor guard this far below its clearance is held up (and the frame solved again).
constexpr double kGuardTolerance_m = 0.001;
/// m: a foot's last planted point held off the floor by more than this is let go (the foot
/// has lifted: a kneel on a foot the character cannot roll onto its edge); a smaller miss is
/// kept pinned (and reported).
constexpr double kLiftOff_m = 0.02;
/// A planted point's miss counts as upward (off the floor) or downward (into it) when its
/// vertical part is over half of it (30 degrees off the vertical at most... 60 from level).
constexpr double kLiftedCos = 0.5;
const char* const kSides[] = {"l", "r"};

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

Matrix3d rot_z(double angle) {
  return Eigen::AngleAxisd(angle, Vector3d::UnitZ()).toRotationMatrix();
}
Matrix3d rot_y(double angle) {
  return Eigen::AngleAxisd(angle, Vector3d::UnitY()).toRotationMatrix();
}
Matrix3d rot_x(double angle) {
  return Eigen::AngleAxisd(angle, Vector3d::UnitX()).toRotationMatrix();
}

/// Heading (rad about +z) of the horizontal part of v; 0 when v is vertical.
double heading(const Vector3d& v) {
  return std::hypot(v.x(), v.y()) < kMinBoneLength_m ? 0.0 : std::atan2(v.y(), v.x());
}

/// Pitch of v above the horizontal, rad.
double pitch(const Vector3d& v) { return std::atan2(v.z(), std::hypot(v.x(), v.y())); }

/// The unit axis across the foot bone x (unit). Away from the vertical it is level (z x x: the
/// free foot has no roll), on the side of `reference` (the capture's own lateral axis of the
/// foot, made normal to x) when that clearly tells, else of `previous` (the last frame's: the
/// capture's foot roll is noisy and, on a foot rolled onto its edge, far from level). Near the
/// vertical, where the level axis is undefined, it blends into the reference.
Vector3d across_axis(const Vector3d& x, const Vector3d& reference, const Vector3d& previous) {
  Vector3d ref = reference - reference.dot(x) * x;
  ref = ref.norm() > kMinBoneLength_m ? Vector3d(ref.normalized()) : previous;
  Vector3d level = Vector3d::UnitZ().cross(x);
  const double n = level.norm();
  if (n < kMinBoneLength_m) return ref;
  level /= n;
  const double w = smoothstep((n - kSteepFootSin) / kSteepFootSin);
  const bool reference_tells = w < 1.0 || std::abs(level.dot(ref)) >= kClearSideCos;
  if (level.dot(reference_tells ? ref : previous) < 0) level = -level;
  return (w * level + (1.0 - w) * ref).normalized();
}

/// Angle turning direction a into direction b about axis y, rad (right-handed: + turns x down
/// about a left-pointing y).
double angle_about(const Vector3d& a, const Vector3d& b, const Vector3d& y) {
  return std::atan2(a.cross(b).dot(y), a.dot(b));
}

/// rad: a joint this close to an end of its range counts as held there.
constexpr double kAtLimit_rad = 0.5 * kRadPerDeg;

/// Names of the limited joints of the leg on `side` ('l' or 'r': joints on the thigh, shank, foot
/// and toes bodies) within kAtLimit_rad of an end of their range at `qpos` (a ball joint: its
/// rotation angle at the cone's limit).
std::vector<std::string> leg_joints_at_limit(const mjModel& m, const mjtNum* qpos, char side) {
  std::vector<std::string> out;
  for (int j = 0; j < m.njnt; ++j) {
    if (!m.jnt_limited[j]) continue;
    const char* body = mj_id2name(&m, mjOBJ_BODY, m.jnt_bodyid[j]);
    const std::string b = body ? body : "";
    const bool leg = b.size() > 2 && b[b.size() - 2] == '_' && b.back() == side &&
                     (b.rfind("thigh", 0) == 0 || b.rfind("shank", 0) == 0 ||
                      b.rfind("foot", 0) == 0 || b.rfind("toes", 0) == 0);
    if (!leg) continue;
    const mjtNum* q = qpos + m.jnt_qposadr[j];
    const double lo = m.jnt_range[2 * j], hi = m.jnt_range[2 * j + 1];
    bool at_limit = false;
    if (m.jnt_type[j] == mjJNT_HINGE || m.jnt_type[j] == mjJNT_SLIDE) {
      at_limit = q[0] < lo + kAtLimit_rad || q[0] > hi - kAtLimit_rad;
    } else if (m.jnt_type[j] == mjJNT_BALL) {
      const double angle = 2.0 * std::atan2(std::sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]),
                                            std::abs(q[0]));
      at_limit = angle > hi - kAtLimit_rad;
    }
    const char* name = mj_id2name(&m, mjOBJ_JOINT, j);
    if (at_limit) out.push_back(name ? name : "joint" + std::to_string(j));
  }
  return out;
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

size_t at(int i) { return static_cast<size_t>(i); }

// ----------------------------------------------------------------------------------------------
// Contact detection
// ----------------------------------------------------------------------------------------------

using Interval = std::pair<int, int>;  // first, last frame (inclusive)

/// Contact intervals of one tracked point (world frame, m): near its stance level (`level`
/// receives it: the median height over the frames where the point is slow) and nearly still,
/// with hysteresis; short gaps bridged and short contacts dropped.
std::vector<Interval> detect_point(const std::vector<Vector3d>& p, double dt,
                                   const ContactOptions& o, double* level) {
  const int n = static_cast<int>(p.size());
  const int w = std::max(1, static_cast<int>(std::lround(o.speed_window_s / dt)));
  std::vector<double> speed(p.size());
  for (int f = 0; f < n; ++f) {
    const int a = std::max(0, f - w), b = std::min(n - 1, f + w);
    const Vector3d d = p[at(b)] - p[at(a)];
    speed[at(f)] = b > a ? std::hypot(d.x(), d.y()) / ((b - a) * dt) : 0.0;
  }
  std::vector<double> slow_z;
  for (int f = 0; f < n; ++f) {
    if (speed[at(f)] < o.enter_speed_m_s) slow_z.push_back(p[at(f)].z());
  }
  if (slow_z.empty()) {  // never still: the lowest height is the level
    double lo = std::numeric_limits<double>::infinity();
    for (const Vector3d& q : p) lo = std::min(lo, q.z());
    slow_z.push_back(lo);
  }
  *level = median(slow_z);

  std::vector<Interval> raw;
  bool in = false;
  for (int f = 0; f < n; ++f) {
    const double h = p[at(f)].z() - *level;
    const double v = speed[at(f)];
    if (!in && h < o.enter_height_m && v < o.enter_speed_m_s) {
      in = true;
      raw.push_back({f, f});
    } else if (in && (h > o.exit_height_m || v > o.exit_speed_m_s)) {
      in = false;
    }
    if (in) raw.back().second = f;
  }
  const int min_frames = std::max(1, static_cast<int>(std::lround(o.min_duration_s / dt)));
  std::vector<Interval> bridged;
  for (const Interval& i : raw) {
    if (!bridged.empty() && i.first - bridged.back().second - 1 < min_frames) {
      bridged.back().second = i.second;
    } else {
      bridged.push_back(i);
    }
  }
  std::vector<Interval> out;
  for (const Interval& i : bridged) {
    if (i.second - i.first + 1 >= min_frames) out.push_back(i);
  }
  return out;
}

std::vector<bool> flags(const std::vector<Interval>& intervals, int frames) {
  std::vector<bool> out(at(frames), false);
  for (const Interval& i : intervals) {
    for (int f = i.first; f <= i.second; ++f) out[at(f)] = true;
  }
  return out;
}

// ----------------------------------------------------------------------------------------------
// Keypoints and sole points on the character
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

/// The marker part naming the body that carries `segment` (the gait trunk is carried by the
/// lumbar part's body).
std::string part_of(const std::string& segment) { return segment == "trunk" ? "lumbar" : segment; }

/// The mapped keypoints of `c`, parents before children: segment origins in the character's
/// order, then the segment ends. A keypoint's parent is the nearest mapped one up the tree.
std::vector<Keypoint> character_keypoints(const models::Character& c, const JointMap& map,
                                          const BvhMotion& motion) {
  std::vector<Keypoint> kps;
  std::map<std::string, int> index;
  const auto add = [&](const std::string& name, const Vector3d& o_W, const std::string& start,
                       const std::string& site_segment) {
    const KeypointMapping* m = map.find(name);
    if (m == nullptr) return;
    Keypoint k;
    k.name = name;
    k.map = *m;
    k.o_W = o_W;
    k.site_segment = site_segment;
    for (const std::string& j : m->joints) k.bvh.push_back(find_bvh_joint(motion, j));
    k.frame_joint = find_bvh_joint(motion, m->frame_joint());
    for (std::string s = start; !s.empty(); s = c.find(s)->parent) {
      const auto it = index.find(s);
      if (it != index.end()) {
        k.parent = it->second;
        break;
      }
    }
    if (name != "pelvis" && k.parent < 0) return;  // nothing above it is mapped
    index[name] = static_cast<int>(kps.size());
    kps.push_back(k);
  };
  // A joint centre's site rides on the parent segment (the pelvis's own origin on the pelvis),
  // so the pelvis carries the hips and lumbar sites the IK's rigid root fit needs.
  for (const models::Segment& s : c.segments) {
    add(s.name, s.origin_W, s.parent, s.parent.empty() ? s.name : s.parent);
  }
  for (const models::Segment& s : c.segments) add(s.name + "_end", segment_end_W(s), s.name, s.name);
  return kps;
}

int keypoint_index(const std::vector<Keypoint>& kps, const std::string& name) {
  for (size_t i = 0; i < kps.size(); ++i) {
    if (kps[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

/// The sole points of a foot: the bottom corners of the heel (foot body), under the MTP joint
/// (toes body) and the toe tip (toes body), in their body frames.
struct Sole {
  static constexpr const char* kNames[kSoles] = {"heel_med", "heel_lat", "ball_med", "ball_lat",
                                                 "tip"};
  std::array<Vector3d, kSoles> point_B;
  static bool on_toes(int p) { return p >= 2; }
};

Sole sole_of(const models::Character& c, const std::string& side) {
  const models::Geom& fb = c.find("foot_" + side)->geoms.front();
  const models::Geom& tb = c.find("toes_" + side)->geoms.front();
  const double lateral = side == "l" ? 1.0 : -1.0;  // +y is the left side
  const double heel_x = fb.center_B.x() - fb.half_extents.x();
  const double foot_sole = fb.center_B.z() - fb.half_extents.z();
  const double ball_x = tb.center_B.x() - tb.half_extents.x();
  const double tip_x = tb.center_B.x() + tb.half_extents.x();
  const double toes_sole = tb.center_B.z() - tb.half_extents.z();
  Sole s;
  s.point_B[0] = Vector3d(heel_x, fb.center_B.y() - lateral * fb.half_extents.y(), foot_sole);
  s.point_B[1] = Vector3d(heel_x, fb.center_B.y() + lateral * fb.half_extents.y(), foot_sole);
  s.point_B[2] = Vector3d(ball_x, tb.center_B.y() - lateral * tb.half_extents.y(), toes_sole);
  s.point_B[3] = Vector3d(ball_x, tb.center_B.y() + lateral * tb.half_extents.y(), toes_sole);
  s.point_B[4] = Vector3d(tip_x, tb.center_B.y(), toes_sole);
  return s;
}

// ----------------------------------------------------------------------------------------------
// The capture
// ----------------------------------------------------------------------------------------------

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

Capture sample(const BvhMotion& motion, const BvhUnits& units) {
  Capture cap;
  cap.poses.reserve(at(motion.frame_count()));
  for (int f = 0; f < motion.frame_count(); ++f) {
    cap.poses.push_back(forward_kinematics(motion, f, units));
  }
  BvhMotion rest = motion;
  rest.values = Eigen::MatrixXd::Zero(1, motion.channel_count());
  cap.rest = forward_kinematics(rest, 0, units);
  return cap;
}

// ----------------------------------------------------------------------------------------------
// Feet
// ----------------------------------------------------------------------------------------------

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
  std::vector<Matrix3d> r_free;   ///< free foot orientation (level roll), per frame
  std::vector<double> toe;        ///< rad, toes turned about the foot's y axis (+: down)
  std::vector<Vector3d> ankle;    ///< m, free ankle target
  std::vector<SolePoints> free;   ///< m, free sole points (level roll)
  std::array<std::vector<Interval>, kSoles> contacts;
  std::vector<std::array<bool, kSoles>> planted;
  std::vector<SolePoints> plant;  ///< m, where planted
  std::vector<FootCorrection> correction;
  std::vector<SolePoints> extra;  ///< m, each point's faded mismatch near its contacts
  std::array<std::vector<bool>, kSoles> released;  ///< per contact: ended by a release
  std::vector<bool> stance;       ///< any point planted
  std::vector<double> roll_weight;  ///< 1 in mid-swing (roll free), 0 near and in stance
  /// Per point, 1 in contact fading to 0 over `blend` frames before and after (a released
  /// contact ends at once): how much of the contact weight the point carries.
  std::vector<std::array<double, kSoles>> contact_share;

  int frames() const { return static_cast<int>(ankle.size()); }

  /// Free sole points at frame f with the foot rolled by `roll` (rad) about its long axis.
  SolePoints free_points(int f, double roll) const {
    const Matrix3d r = r_free[at(f)] * rot_x(roll);
    const Matrix3d r_toes = r * rot_y(toe[at(f)]);
    const Vector3d a = ankle[at(f)];
    const Vector3d m = a + r * ankle_to_mtp_W;
    SolePoints out;
    for (int p = 0; p < kSoles; ++p) {
      out[at(p)] = Sole::on_toes(p) ? Vector3d(m + r_toes * sole.point_B[at(p)])
                                    : Vector3d(a + r * sole.point_B[at(p)]);
    }
    return out;
  }

  /// Targets at frame f of the sole points and the ankle: planted points at their plants, the
  /// others corrected, never below the floor (the free points and the ankle lifted together).
  void compose(int f, double roll, SolePoints* sole_target, Vector3d* ankle_target) const {
    const SolePoints F = roll == 0.0 ? free[at(f)] : free_points(f, roll);
    const FootCorrection& c = correction[at(f)];
    double lowest = 0.0;
    for (int p = 0; p < kSoles; ++p) {
      if (planted[at(f)][at(p)]) {
        (*sole_target)[at(p)] = plant[at(f)][at(p)];
        continue;
      }
      (*sole_target)[at(p)] = c.apply(F[at(p)], ankle[at(f)]) + extra[at(f)][at(p)];
      lowest = std::min(lowest, (*sole_target)[at(p)].z());
    }
    for (int p = 0; p < kSoles; ++p) {
      if (!planted[at(f)][at(p)]) (*sole_target)[at(p)].z() -= lowest;
    }
    *ankle_target = ankle[at(f)] + c.t - Vector3d(0.0, 0.0, lowest);
  }
};

/// Pins the foot's contacts (pass 1: plants and the correction fitted to them), fades the
/// correction off the stance, and fades each point's own mismatch in before its touch-down and
/// out after its lift-off (pass 2).
void plant(FootTrack* t, int blend) {
  const int frames = t->frames();
  std::array<std::vector<bool>, kSoles> on;
  for (int p = 0; p < kSoles; ++p) on[at(p)] = flags(t->contacts[at(p)], frames);
  t->planted.assign(at(frames), std::array<bool, kSoles>{});
  t->plant.assign(at(frames), SolePoints{});
  t->correction.assign(at(frames), FootCorrection{});
  t->stance.assign(at(frames), false);

  // Pass 1. A point touching down while others are planted lands where the corrected foot
  // puts it (so the planted points keep the foot's shape); from the air, where it is.
  SolePoints plant_at;
  plant_at.fill(Vector3d::Zero());
  std::array<bool, kSoles> is_planted{};
  // The correction fitted to the planted points: translation from their means, yaw (about the
  // ankle) when they are spread out, else `held`.
  const auto fit = [&](int f, const FootCorrection& held, int* n) {
    const SolePoints& F = t->free[at(f)];
    const Vector3d& a = t->ankle[at(f)];
    Vector3d mu = Vector3d::Zero(), mv = Vector3d::Zero();
    *n = 0;
    for (int p = 0; p < kSoles; ++p) {
      if (!is_planted[at(p)]) continue;
      mu += F[at(p)] - a;
      mv += plant_at[at(p)] - a;
      ++*n;
    }
    if (*n == 0) return FootCorrection{};
    mu /= *n;
    mv /= *n;
    double cross = 0.0, dot = 0.0, spread = 0.0;
    for (int p = 0; p < kSoles; ++p) {
      if (!is_planted[at(p)]) continue;
      const Vector3d u = F[at(p)] - a - mu, v = plant_at[at(p)] - a - mv;
      cross += u.x() * v.y() - u.y() * v.x();
      dot += u.x() * v.x() + u.y() * v.y();
      spread += u.x() * u.x() + u.y() * u.y();
    }
    FootCorrection c;
    c.yaw = spread > kMinYawSpread_m2 * *n ? std::atan2(cross, dot) : held.yaw;
    c.t = mv - rot_z(c.yaw) * mu;
    return c;
  };
  for (int f = 0; f < frames; ++f) {
    const SolePoints& F = t->free[at(f)];
    const FootCorrection held = f > 0 && t->stance[at(f - 1)] ? t->correction[at(f - 1)]
                                                              : FootCorrection{};
    int n = 0;
    const FootCorrection before = fit(f, held, &n);
    for (int p = 0; p < kSoles; ++p) {
      if (!on[at(p)][at(f)] || is_planted[at(p)]) continue;
      plant_at[at(p)] = n > 0 ? before.apply(F[at(p)], t->ankle[at(f)]) : F[at(p)];
      plant_at[at(p)].z() = 0.0;  // the sole on the floor
      is_planted[at(p)] = true;
    }
    t->correction[at(f)] = fit(f, held, &n);
    t->stance[at(f)] = n > 0;
    for (int p = 0; p < kSoles; ++p) {
      if (!is_planted[at(p)]) continue;
      t->planted[at(f)][at(p)] = true;
      t->plant[at(f)][at(p)] = plant_at[at(p)];
      if (f + 1 >= frames || !on[at(p)][at(f + 1)]) is_planted[at(p)] = false;
    }
  }

  // Off the stance: the correction fades out after lift-off and in before touch-down, over at
  // most `blend` frames (half the swing when it is shorter); the roll is free in mid-swing.
  const std::vector<FootCorrection> c = t->correction;
  t->roll_weight.assign(at(frames), 0.0);
  for (int f = 0; f < frames;) {
    if (t->stance[at(f)]) {
      ++f;
      continue;
    }
    const int a = f;
    while (f < frames && !t->stance[at(f)]) ++f;
    const int b = f - 1;  // swing [a, b]
    const double len = std::max(1.0, std::min<double>(blend, (b - a + 2) / 2));
    for (int g = a; g <= b; ++g) {
      FootCorrection v;
      double w_out = 0.0, w_in = 0.0;
      if (a > 0) {
        w_out = 1.0 - smoothstep((g - (a - 1)) / len);
        v = v.plus(c[at(a - 1)].scaled(w_out));
      }
      if (b + 1 < frames) {
        w_in = 1.0 - smoothstep(((b + 1) - g) / len);
        v = v.plus(c[at(b + 1)].scaled(w_in));
      }
      t->correction[at(g)] = v;
      t->roll_weight[at(g)] = 1.0 - std::max(w_out, w_in);
    }
  }

  // Each point's share of the contact weight.
  t->contact_share.assign(at(frames), std::array<double, kSoles>{});
  for (int p = 0; p < kSoles; ++p) {
    const std::vector<Interval>& ints = t->contacts[at(p)];
    t->released[at(p)].resize(ints.size(), false);
    for (size_t k = 0; k < ints.size(); ++k) {
      const int fade_out = t->released[at(p)][k] ? 1 : blend;
      for (int g = std::max(0, ints[k].first - blend);
           g <= std::min(frames - 1, ints[k].second + fade_out); ++g) {
        double share = 1.0;
        if (g < ints[k].first) share = smoothstep(1.0 - (ints[k].first - g) / (blend + 1.0));
        if (g > ints[k].second) share = smoothstep(1.0 - (g - ints[k].second) / (fade_out + 1.0));
        t->contact_share[at(g)][at(p)] = std::max(t->contact_share[at(g)][at(p)], share);
      }
    }
  }

  // Pass 2.
  t->extra.assign(at(frames), SolePoints{});
  for (SolePoints& e : t->extra) e.fill(Vector3d::Zero());
  for (int p = 0; p < kSoles; ++p) {
    const std::vector<Interval>& ints = t->contacts[at(p)];
    const auto corrected = [&](int f) {
      return t->correction[at(f)].apply(t->free[at(f)][at(p)], t->ankle[at(f)]);
    };
    for (size_t k = 0; k < ints.size(); ++k) {
      const int t0 = ints[k].first, t1 = ints[k].second;
      const Vector3d pl = t->plant[at(t0)][at(p)];
      const int prev_end = k > 0 ? ints[k - 1].second : -1;
      const int next_start = k + 1 < ints.size() ? ints[k + 1].first : frames;
      if (t0 > 0) {
        const Vector3d m0 = pl - corrected(t0);
        const int len = std::max(1, std::min(blend, t0 - prev_end - 1));
        for (int g = std::max(prev_end + 1, t0 - len); g < t0; ++g) {
          t->extra[at(g)][at(p)] += m0 * smoothstep(static_cast<double>(g - (t0 - 1 - len)) / len);
        }
      }
      if (t1 + 1 < frames) {
        const Vector3d m1 = pl - corrected(t1 + 1);
        const int len = std::max(1, std::min(blend, next_start - t1 - 1));
        for (int g = t1 + 1; g <= std::min(t1 + len, next_start - 1); ++g) {
          t->extra[at(g)][at(p)] += m1 * (1.0 - smoothstep(static_cast<double>(g - t1 - 1) / len));
        }
      }
    }
  }
}

/// Ends point p's contact at frame f (drops it if it starts there) and plans the foot again;
/// frames before f keep their targets.
void release(FootTrack* t, int p, int f, int blend) {
  std::vector<Interval>& ints = t->contacts[at(p)];
  for (size_t k = 0; k < ints.size(); ++k) {
    if (ints[k].first > f || ints[k].second < f) continue;
    t->released[at(p)].resize(ints.size(), false);
    if (ints[k].first == f) {
      ints.erase(ints.begin() + static_cast<long>(k));
      t->released[at(p)].erase(t->released[at(p)].begin() + static_cast<long>(k));
    } else {
      ints[k].second = f - 1;
      t->released[at(p)][k] = true;
    }
    break;
  }
  plant(t, blend);
}

/// Geometry of the lowest point of a geom along the world z, m (z of its centre less its
/// extent); +inf for planes and unsupported types.
double geom_lowest_z(const mjModel& m, const mjData& d, int g) {
  const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> r(d.geom_xmat + 9 * g);
  const double* size = m.geom_size + 3 * g;
  const double zc = d.geom_xpos[3 * g + 2];
  switch (m.geom_type[g]) {
    case mjGEOM_BOX:
      return zc - std::abs(r(2, 0)) * size[0] - std::abs(r(2, 1)) * size[1] -
             std::abs(r(2, 2)) * size[2];
    case mjGEOM_CAPSULE:
      return zc - std::abs(r(2, 2)) * size[1] - size[0];
    case mjGEOM_SPHERE:
      return zc - size[0];
    default:
      return std::numeric_limits<double>::infinity();
  }
}

}  // namespace

// ----------------------------------------------------------------------------------------------
// Options
// ----------------------------------------------------------------------------------------------

void ContactOptions::validate() const {
  const auto positive = [](double v, const char* field) {
    if (!(v > 0) || !std::isfinite(v)) {
      throw InvalidArgument(std::string("contacts.") + field + ": must be > 0, got " +
                            std::to_string(v));
    }
  };
  positive(enter_height_m, "enter_height_m");
  positive(exit_height_m, "exit_height_m");
  positive(enter_speed_m_s, "enter_speed_m_s");
  positive(exit_speed_m_s, "exit_speed_m_s");
  positive(min_duration_s, "min_duration_s");
  positive(speed_window_s, "speed_window_s");
  if (exit_height_m < enter_height_m) {
    throw InvalidArgument("contacts.exit_height_m: must be >= enter_height_m (" +
                          std::to_string(enter_height_m) + "), got " +
                          std::to_string(exit_height_m));
  }
  if (exit_speed_m_s < enter_speed_m_s) {
    throw InvalidArgument("contacts.exit_speed_m_s: must be >= enter_speed_m_s (" +
                          std::to_string(enter_speed_m_s) + "), got " +
                          std::to_string(exit_speed_m_s));
  }
}

void RetargetOptions::validate() const {
  if (units && !(units->metres_per_unit > 0 && std::isfinite(units->metres_per_unit))) {
    throw InvalidArgument("units.metres_per_unit: must be > 0, got " +
                          std::to_string(units->metres_per_unit));
  }
  if (!(output_units.metres_per_unit > 0 && std::isfinite(output_units.metres_per_unit))) {
    throw InvalidArgument("output_units.metres_per_unit: must be > 0, got " +
                          std::to_string(output_units.metres_per_unit));
  }
  contacts.validate();
  if (!(contact_weight > 0) || !std::isfinite(contact_weight)) {
    throw InvalidArgument("contact_weight: must be > 0, got " + std::to_string(contact_weight));
  }
  if (!(swing_weight > 0) || !std::isfinite(swing_weight)) {
    throw InvalidArgument("swing_weight: must be > 0, got " + std::to_string(swing_weight));
  }
  if (!(release_error_m > 0) || !std::isfinite(release_error_m)) {
    throw InvalidArgument("release_error_m: must be > 0, got " + std::to_string(release_error_m));
  }
  if (!(blend_s >= 0) || !std::isfinite(blend_s)) {
    throw InvalidArgument("blend_s: must be >= 0, got " + std::to_string(blend_s));
  }
  ik.validate();
}

// ----------------------------------------------------------------------------------------------
// Retargeting
// ----------------------------------------------------------------------------------------------

RetargetResult retarget_bvh(const BvhMotion& motion, const JointMap& map,
                            const models::CharacterSpec& spec, const RetargetOptions& options,
                            const std::function<void(double)>& progress) {
  const auto t_start = std::chrono::steady_clock::now();
  options.validate();
  const BvhUnits units = options.units ? *options.units : (map.units ? *map.units : BvhUnits{});
  if (!(units.metres_per_unit > 0)) {
    throw InvalidArgument("joint map " + map.name + ": units.metres_per_unit must be > 0");
  }
  const JointMap resolved = resolve_joint_map(map, motion, options.source);
  const int frames = motion.frame_count();
  if (frames < 1) throw InvalidArgument(options.source + ": the BVH has no frames");
  if (!(motion.frame_time_s > 0)) {
    throw InvalidArgument(options.source + ": frame time must be > 0 s, got " +
                          std::to_string(motion.frame_time_s));
  }
  const double dt = motion.frame_time_s;
  // Contact windows and fades are counted in frames: a frame time outside what capture systems
  // record (10 kHz to one frame per 10 s) would overflow or empty them.
  if (dt < kMinFrameTime_s || dt > kMaxFrameTime_s) {
    throw InvalidArgument(options.source + ": frame time must be within [" +
                          std::to_string(kMinFrameTime_s) + ", " +
                          std::to_string(kMaxFrameTime_s) + "] s, got " + std::to_string(dt));
  }

  // The character's geometry (its markers are replaced below; they move nothing).
  models::CharacterSpec plain_spec = spec;
  plain_spec.markers.clear();
  const models::Character plain = models::generate_character(plain_spec);
  const std::vector<Keypoint> kps = character_keypoints(plain, resolved, motion);
  const auto kp = [&](const std::string& name) -> const Keypoint& {
    const int i = keypoint_index(kps, name);
    if (i < 0) {
      throw InvalidArgument(options.source + ": joint map '" + map.name +
                            "' places no keypoint '" + name + "' on this character");
    }
    return kps[at(i)];
  };
  const Capture cap = sample(motion, units);
  for (int f = 0; f < frames; ++f) {
    const auto& p = cap.poses[at(f)].positions_W;
    if (!p.allFinite() || p.cwiseAbs().maxCoeff() > kMaxCaptureExtent_m) {
      throw InvalidArgument(options.source + ": frame " + std::to_string(f) +
                            " has joint positions not finite or beyond " +
                            std::to_string(kMaxCaptureExtent_m) +
                            " m of the origin (metres per unit " +
                            std::to_string(units.metres_per_unit) + ")");
    }
  }

  // Scale by leg length; the vertical scales about the ankles' stance level. The BVH's ankle
  // and MTP joints' contacts (heel and ball on the floor) tell where that level is and which
  // frames have the foot flat.
  double bvh_leg = 0.0, char_leg = 0.0, char_ankle_h = 0.0, bvh_ankle_level = 0.0;
  std::array<std::vector<Interval>, 2> bvh_heel, bvh_ball;
  for (int s = 0; s < 2; ++s) {
    const std::string sd = kSides[s];
    const Keypoint &hip = kp("thigh_" + sd), &knee = kp("shank_" + sd), &ankle = kp("foot_" + sd),
                   &mtp = kp("toes_" + sd);
    // Every leg bone needs a length: a direction is taken from each (a map that puts two
    // keypoints on one joint would give a foot frame that is not a rotation).
    const std::array<std::pair<const Keypoint*, const Keypoint*>, 3> bones = {
        {{&hip, &knee}, {&knee, &ankle}, {&ankle, &mtp}}};
    for (const auto& [from, to] : bones) {
      const double length = (cap.rest_position(*from) - cap.rest_position(*to)).norm();
      if (!(length > kMinBoneLength_m)) {
        throw InvalidArgument(options.source + ": joint map '" + map.name + "': keypoints " +
                              from->name + " and " + to->name +
                              " are at the same place in the BVH's rest pose (bone length " +
                              std::to_string(length) + " m); map them to different joints");
      }
    }
    bvh_leg += 0.5 * ((cap.position(hip, 0) - cap.position(knee, 0)).norm() +
                      (cap.position(knee, 0) - cap.position(ankle, 0)).norm());
    char_leg += 0.5 * (plain.find("thigh_" + sd)->length_m + plain.find("shank_" + sd)->length_m);
    char_ankle_h += 0.5 * plain.find("foot_" + sd)->origin_W.z();
    std::vector<Vector3d> a, m;
    for (int f = 0; f < frames; ++f) {
      a.push_back(cap.position(ankle, f));
      m.push_back(cap.position(mtp, f));
    }
    double heel_level = 0.0, ball_level = 0.0;
    bvh_heel[at(s)] = detect_point(a, dt, options.contacts, &heel_level);
    bvh_ball[at(s)] = detect_point(m, dt, options.contacts, &ball_level);
    bvh_ankle_level += 0.5 * heel_level;
  }
  if (!(bvh_leg > kMinBoneLength_m)) {
    throw InvalidArgument(options.source + ": the BVH's legs (hip-knee + knee-ankle) have zero "
                                           "length; check the joint map");
  }
  const double scale = char_leg / bvh_leg;

  // Facing: the BVH's rest pose faces left x up; the character's rest faces +x.
  const Vector3d rest_left = cap.rest_position(kp("thigh_l")) - cap.rest_position(kp("thigh_r"));
  const Matrix3d r_face = rot_z(heading(Vector3d(rest_left.y(), -rest_left.x(), 0.0)));
  const Keypoint& pelvis = kp("pelvis");
  const auto root_position = [&](int f) {
    const Vector3d b = cap.position(pelvis, f);
    return Vector3d(scale * b.x(), scale * b.y(), scale * (b.z() - bvh_ankle_level) + char_ankle_h);
  };
  Matrix3d r_align = Matrix3d::Identity();
  Vector3d t_align = Vector3d::Zero();
  if (options.align_start) {
    r_align = rot_z(-heading(cap.from_rest(pelvis.frame_joint, 0) * r_face * Vector3d::UnitX()));
    const Vector3d p0 = r_align * root_position(0);
    t_align = Vector3d(-p0.x(), -p0.y(), 0.0);
  }

  // The feet are read from the capture's bones: ankle -> MTP gives the foot's heading and pitch,
  // MTP -> toe tip (when mapped) the toes' pitch on the foot. "Flat" is measured on the
  // capture's own flat-foot frames (the rest pose if there are too few), so rigs whose joints
  // sit at other heights in the foot, or whose rest pose pitches the foot, still land the sole
  // flat. The free roll is level: a marker-based foot bone's roll about itself is poorly seen.
  std::array<FootTrack, 2> feet;
  std::array<double, 2> flat_pitch{}, flat_toe_pitch{};
  std::array<Vector3d, 2> flat_lateral_A;
  std::array<int, 2> i_ankle{}, i_mtp{}, i_tip{};
  for (int s = 0; s < 2; ++s) {
    const std::string sd = kSides[s];
    i_ankle[at(s)] = keypoint_index(kps, "foot_" + sd);
    i_mtp[at(s)] = keypoint_index(kps, "toes_" + sd);
    i_tip[at(s)] = keypoint_index(kps, "toes_" + sd + "_end");
    const Keypoint& ankle = kp("foot_" + sd);
    const Keypoint& mtp = kp("toes_" + sd);
    const Keypoint* tip = i_tip[at(s)] >= 0 ? &kps[at(i_tip[at(s)])] : nullptr;
    const std::vector<bool> heel_on = flags(bvh_heel[at(s)], frames);
    const std::vector<bool> ball_on = flags(bvh_ball[at(s)], frames);
    // On a flat foot: the bone's pitch, the toe bone's angle on it (about the level axis across
    // it; +: down) and the level axis in the ankle joint's frame (the capture's own lateral axis
    // of the foot, used where the bone is steep).
    std::vector<double> foot_pitches, toe_angles;
    Vector3d lateral_A = Vector3d::Zero();
    const auto flat_sample = [&](const Vector3d& a, const Vector3d& m, const Vector3d* e,
                                 const Matrix3d& r_wa) {
      const Vector3d x = (m - a).normalized();
      const Vector3d y = Vector3d::UnitZ().cross(x).normalized();
      foot_pitches.push_back(pitch(x));
      if (e) toe_angles.push_back(angle_about(x, *e - m, y));
      lateral_A += r_wa.transpose() * y;
    };
    for (int f = 0; f < frames; ++f) {
      if (!heel_on[at(f)] || !ball_on[at(f)]) continue;
      const Vector3d e = tip ? cap.position(*tip, f) : Vector3d::Zero();
      flat_sample(cap.position(ankle, f), cap.position(mtp, f), tip ? &e : nullptr,
                  cap.poses[at(f)].rotations_W[at(ankle.frame_joint)]);
    }
    if (static_cast<int>(foot_pitches.size()) < kMinFlatFrames) {
      foot_pitches.clear();
      toe_angles.clear();
      lateral_A.setZero();
      const Vector3d e = tip ? cap.rest_position(*tip) : Vector3d::Zero();
      flat_sample(cap.rest_position(ankle), cap.rest_position(mtp), tip ? &e : nullptr,
                  cap.rest.rotations_W[at(ankle.frame_joint)]);
    }
    flat_pitch[at(s)] = median(foot_pitches);
    flat_toe_pitch[at(s)] = tip ? median(toe_angles) : 0.0;
    flat_lateral_A[at(s)] = lateral_A.normalized();
    FootTrack& t = feet[at(s)];
    t.sole = sole_of(plain, sd);
    t.ankle_to_mtp_W = mtp.o_W - ankle.o_W;
    t.r_free.resize(at(frames));
    t.toe.resize(at(frames));
    t.ankle.resize(at(frames));
    t.free.resize(at(frames));
  }

  // Free targets: each keypoint from its parent's, on the character's proportions.
  const int nk = static_cast<int>(kps.size());
  std::vector<Eigen::Matrix3Xd> kp_target(at(frames), Eigen::Matrix3Xd(3, nk));
  std::array<Vector3d, 2> across;  // the axis across each foot bone at the frame before
  across.fill(r_align * r_face * Vector3d::UnitY());
  for (int f = 0; f < frames; ++f) {
    Eigen::Matrix3Xd& t = kp_target[at(f)];
    for (int i = 0; i < nk; ++i) {
      const Keypoint& k = kps[at(i)];
      if (k.parent < 0) {
        t.col(i) = r_align * root_position(f) + t_align;
        continue;
      }
      if (k.name.rfind("toes_", 0) == 0) continue;  // from the foot, below
      const Keypoint& p = kps[at(k.parent)];
      const Vector3d rest_offset = k.o_W - p.o_W;
      const Vector3d bone = r_align * (cap.position(k, f) - cap.position(p, f));
      if (k.map.rigid || bone.norm() < kMinBoneLength_m) {
        t.col(i) = t.col(k.parent) +
                   r_align * cap.from_rest(p.frame_joint, f) * r_face * rest_offset;
      } else {
        t.col(i) = t.col(k.parent) + rest_offset.norm() * bone.normalized();
      }
    }
    for (int s = 0; s < 2; ++s) {
      FootTrack& foot = feet[at(s)];
      const Vector3d bvh_m = cap.position(kps[at(i_mtp[at(s)])], f);
      const Vector3d foot_bone = r_align * (bvh_m - cap.position(kps[at(i_ankle[at(s)])], f));
      // The bone's frame (x along it, y across it), turned back by the flat pitch: the
      // character's foot is flat when the capture's bone has its flat pitch.
      const Vector3d x = foot_bone.normalized();
      const Matrix3d& r_wa = cap.poses[at(f)].rotations_W[at(kps[at(i_ankle[at(s)])].frame_joint)];
      const Vector3d y = across_axis(x, r_align * r_wa * flat_lateral_A[at(s)], across[at(s)]);
      across[at(s)] = y;
      Matrix3d r_bone;
      r_bone << x, y, x.cross(y);
      foot.r_free[at(f)] = r_bone * rot_y(flat_pitch[at(s)]);
      foot.toe[at(f)] = 0.0;
      if (i_tip[at(s)] >= 0) {
        const Vector3d toe_bone = r_align * (cap.position(kps[at(i_tip[at(s)])], f) - bvh_m);
        foot.toe[at(f)] = angle_about(x, toe_bone, y) - flat_toe_pitch[at(s)];
      }
      foot.ankle[at(f)] = t.col(i_ankle[at(s)]);
      foot.free[at(f)] = foot.free_points(f, 0.0);
    }
  }

  // Contacts of the sole points, on their free trajectories (the capture's foot motion on the
  // character's sole): a heel, a ball or the tip can touch alone (heel strike, heel-off, a
  // pivot on the toes, kneeling on tucked toes). Then the pins.
  const int blend = std::max(1, static_cast<int>(std::lround(options.blend_s / dt)));
  for (FootTrack& foot : feet) {
    for (int p = 0; p < kSoles; ++p) {
      std::vector<Vector3d> track(at(frames));
      for (int f = 0; f < frames; ++f) track[at(f)] = foot.free[at(f)][at(p)];
      double level = 0.0;
      foot.contacts[at(p)] = detect_point(track, dt, options.contacts, &level);
    }
    plant(&foot, blend);
  }

  // The character with its IK sites: the keypoints (but the toes: the sole points stand in for
  // them) and the sole points.
  RetargetResult result;
  result.spec = spec;
  result.spec.markers.clear();
  std::vector<std::string> labels;
  std::vector<double> weights;
  std::vector<int> label_kp;  // keypoint per keypoint label
  for (int i = 0; i < nk; ++i) {
    const Keypoint& k = kps[at(i)];
    if (k.name.rfind("toes_", 0) == 0) continue;
    models::MarkerPlacement m;
    m.name = "kp_" + k.name;
    m.part = part_of(k.site_segment);
    m.position_B = k.o_W - plain.find(k.site_segment)->origin_W;
    m.description = "retargeting keypoint " + k.name;
    result.spec.markers.push_back(m);
    labels.push_back(m.name);
    weights.push_back(k.map.weight);
    label_kp.push_back(i);
  }
  const int n_kp = static_cast<int>(labels.size());
  for (int s = 0; s < 2; ++s) {
    for (int p = 0; p < kSoles; ++p) {
      models::MarkerPlacement m;
      m.name = std::string("sole_") + Sole::kNames[p] + "_" + kSides[s];
      m.part = std::string(Sole::on_toes(p) ? "toes_" : "foot_") + kSides[s];
      m.position_B = feet[at(s)].sole.point_B[at(p)];
      m.description = "retargeting sole point";
      result.spec.markers.push_back(m);
      labels.push_back(m.name);
      weights.push_back(options.contact_weight);
    }
  }
  // Floor guards: the sole points and the other corners of the foot and toes boxes (clearance
  // 0), and the ends of the shank and thigh capsules (clearance: the radius). Untargeted until
  // a solve puts one below the floor.
  struct Guard {
    int label = 0;
    double clearance_m = 0.0;
  };
  std::vector<Guard> guards;
  for (int i = 0; i < 2 * kSoles; ++i) guards.push_back({n_kp + i, 0.0});
  for (int s = 0; s < 2; ++s) {
    const auto add_guard = [&](const std::string& segment, const std::string& name,
                               const Vector3d& p_B, double clearance) {
      models::MarkerPlacement m;
      m.name = "guard_" + name + "_" + kSides[s];
      m.part = segment;
      m.position_B = p_B;
      m.description = "retargeting floor guard";
      result.spec.markers.push_back(m);
      guards.push_back({static_cast<int>(labels.size()), clearance});
      labels.push_back(m.name);
      weights.push_back(0.0);
    };
    const std::string sd = kSides[s];
    for (const char* seg : {"foot_", "toes_"}) {
      // The box corners the sole points leave out: the front bottom ones and the top ones (a
      // foot rolled onto its edge, as in a kneel, can put a top corner lowest).
      const models::Geom& box = plain.find(seg + sd)->geoms.front();
      for (double up : {-1.0, 1.0}) {
        for (double front : {-1.0, 1.0}) {
          if (up < 0 && front < 0) continue;  // the back bottom corners are sole points
          for (double left : {-1.0, 1.0}) {
            const std::string name = std::string(seg) + (front > 0 ? "front_" : "back_") +
                                     (up > 0 ? "top_" : "bottom_") + (left > 0 ? "left" : "right");
            add_guard(seg + sd, name,
                      box.center_B + box.half_extents.cwiseProduct(Vector3d(front, left, up)),
                      0.0);
          }
        }
      }
    }
    for (const char* seg : {"shank_", "thigh_"}) {
      const models::Geom& capsule = plain.find(seg + sd)->geoms.front();
      add_guard(seg + sd, std::string(seg) + "top", capsule.from_B, capsule.radius);
      add_guard(seg + sd, std::string(seg) + "bottom", capsule.to_B, capsule.radius);
    }
  }
  const int n_labels = static_cast<int>(labels.size());
  const models::Character character = models::generate_character(result.spec);
  const sim::Model model =
      sim::Model::from_string(models::to_mjcf(character), "retargeting character");

  // Targets, as far as they are known before the IK (the swing feet's roll is set during it).
  result.targets.rate_hz = 1.0 / dt;
  result.targets.labels = labels;
  result.targets.positions_m.resize(frames, 3 * n_labels);
  const auto write_feet = [&](int f, const std::array<double, 2>& roll) {
    for (int s = 0; s < 2; ++s) {
      SolePoints sole;
      Vector3d ankle;
      feet[at(s)].compose(f, roll[at(s)], &sole, &ankle);
      for (int p = 0; p < kSoles; ++p) {
        result.targets.positions_m.row(f).segment<3>(3 * (n_kp + s * kSoles + p)) =
            sole[at(p)].transpose();
      }
      for (int l = 0; l < n_kp; ++l) {
        if (label_kp[at(l)] == i_ankle[at(s)]) {
          result.targets.positions_m.row(f).segment<3>(3 * l) = ankle.transpose();
        }
      }
    }
  };
  result.targets.positions_m.setConstant(std::numeric_limits<double>::quiet_NaN());
  for (int f = 0; f < frames; ++f) {
    for (int l = 0; l < n_kp; ++l) {
      result.targets.positions_m.row(f).segment<3>(3 * l) =
          kp_target[at(f)].col(label_kp[at(l)]).transpose();
    }
    write_feet(f, {0.0, 0.0});
  }

  // IK, frame by frame, warm-started. In swing a foot's roll is the IK's own from the frame
  // before (targets follow it: the roll is free), scaled down to level near its contacts, and
  // its sole weighs as a keypoint. A planted point the IK cannot hold is released and the frame
  // solved again: the character lifts its heel (or toes) early where the capture's pose is out
  // of its joints' reach, instead of sliding.
  const auto t_ik = std::chrono::steady_clock::now();
  MarkerIkOptions ik_options = options.ik;
  ik_options.min_visible_fraction = 0.0;  // every frame has its targets; guards are often off
  MarkerIk ik(*model, labels, weights, ik_options);
  sim::Data data(*model);
  std::array<int, 2> foot_body{};
  for (int s = 0; s < 2; ++s) {
    foot_body[at(s)] = model.id(mjOBJ_BODY, std::string("foot_") + kSides[s]);
  }
  std::vector<int> site_of_label(at(n_labels));
  for (int l = 0; l < n_labels; ++l) {
    site_of_label[at(l)] = model.id(mjOBJ_SITE, "marker_" + labels[at(l)]);
  }
  std::vector<mjtNum> q(model->qpos0, model->qpos0 + model->nq), q_start = q;
  Eigen::MatrixXd qpos =
      Eigen::MatrixXd::Constant(frames, model->nq, std::numeric_limits<double>::quiet_NaN());
  Eigen::VectorXd row(3 * n_labels);
  bool have_previous = false;
  long iterations = 0;
  RetargetStats& st = result.stats;
  for (int f = 0; f < frames; ++f) {
    std::array<double, 2> roll{};
    if (have_previous && f > 0) {
      mju_copy(data->qpos, q.data(), model->nq);
      mj_kinematics(model.get(), data.get());
      for (int s = 0; s < 2; ++s) {
        const FootTrack& foot = feet[at(s)];
        const double w = foot.roll_weight[at(f)], w_prev = foot.roll_weight[at(f - 1)];
        if (w <= 0.0) continue;
        const Matrix3d r_act = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(
            data->xmat + 9 * foot_body[at(s)]);
        const Matrix3d r_rel = foot.r_free[at(f - 1)].transpose() * r_act;
        const double measured = std::atan2(r_rel(2, 1), r_rel(1, 1));
        roll[at(s)] = measured * (w_prev > kMinRollWeight ? std::min(1.0, w / w_prev) : 1.0);
      }
    }
    q_start = q;
    std::vector<std::pair<int, Vector3d>> active;  // guard label, its target
    for (int attempt = 0;; ++attempt) {
      write_feet(f, roll);
      for (int s = 0; s < 2; ++s) {
        for (int p = 0; p < kSoles; ++p) {
          weights[at(n_kp + s * kSoles + p)] =
              options.swing_weight + feet[at(s)].contact_share[at(f)][at(p)] *
                                         (options.contact_weight - options.swing_weight);
        }
      }
      for (int l = n_kp + 2 * kSoles; l < n_labels; ++l) {
        weights[at(l)] = 0.0;
        result.targets.positions_m.row(f).segment<3>(3 * l).setConstant(
            std::numeric_limits<double>::quiet_NaN());
      }
      for (const auto& [l, target] : active) {
        weights[at(l)] = kGuardWeightFactor * options.contact_weight;
        result.targets.positions_m.row(f).segment<3>(3 * l) = target.transpose();
      }
      ik.set_weights(weights);
      row = result.targets.positions_m.row(f).transpose();
      q = q_start;
      const MarkerIkFrame fr = ik.solve(row.data(), have_previous, q.data());
      if (!fr.solved) {
        ++st.unsolved_frames;
        break;
      }
      iterations += fr.iterations;
      // A planted point the IK could not hold. Pulled off the floor, it is released (the heel
      // of an early heel-off, the ball of a toe-off pivoting on the tip, the outer edge of a
      // foot rolled onto its inner edge; even a foot's last point: that foot is in the air).
      // Pulled along the floor, it is released only if another point of its foot stays
      // planted, so a stance never vanishes and a slide is never hidden. Pushed into the floor,
      // the far end of the foot lets go instead (the heel rises when the ankle cannot
      // dorsiflex further to keep the ball down).
      mju_copy(data->qpos, q.data(), model->nq);
      mj_kinematics(model.get(), data.get());
      double worst = 0.0;
      int worst_side = -1, worst_point = -1;
      for (int s = 0; s < 2; ++s) {
        const auto& planted = feet[at(s)].planted[at(f)];
        const bool others = std::count(planted.begin(), planted.end(), true) >= 2;
        for (int p = 0; p < kSoles; ++p) {
          if (!planted[at(p)]) continue;
          const Vector3d x(data->site_xpos + 3 * site_of_label[at(n_kp + s * kSoles + p)]);
          const Vector3d e = x - feet[at(s)].plant[at(f)][at(p)];
          const bool lifted = e.z() > kLiftedCos * e.norm() && e.norm() > kLiftOff_m;
          if (e.norm() <= worst || !(others || lifted)) continue;
          if (e.z() < -kLiftedCos * e.norm()) {  // into the floor: the planted point furthest away
            double far = -1.0;
            int release_point = -1;
            for (int o = 0; o < kSoles; ++o) {
              const double d =
                  (feet[at(s)].sole.point_B[at(o)] - feet[at(s)].sole.point_B[at(p)]).norm();
              if (o != p && planted[at(o)] && Sole::on_toes(o) != Sole::on_toes(p) && d > far) {
                far = d;
                release_point = o;
              }
            }
            if (release_point < 0) continue;
            worst_point = release_point;
          } else {
            worst_point = p;
          }
          worst = e.norm();
          worst_side = s;
        }
      }
      if (attempt < kMaxSolvesPerFrame - 1 && worst > options.release_error_m) {
        release(&feet[at(worst_side)], worst_point, f, blend);
        ++st.released_contacts;
        continue;
      }
      // Floor guards below the floor: held up where they are (an active guard still below is
      // aimed higher by what it lacks: the other targets pull it down that much), and the frame
      // solved again.
      bool added = false;
      for (const Guard& g : guards) {
        const Vector3d x(data->site_xpos + 3 * site_of_label[at(g.label)]);
        const double deficit = g.clearance_m - x.z();
        if (deficit <= kGuardTolerance_m) continue;
        const auto it = std::find_if(active.begin(), active.end(),
                                     [&](const auto& a) { return a.first == g.label; });
        if (it == active.end()) {
          active.push_back({g.label, Vector3d(x.x(), x.y(), g.clearance_m)});
        } else {
          it->second.z() += deficit;
        }
        added = true;
      }
      if (added && attempt < kMaxSolvesPerFrame - 1) continue;
      have_previous = true;
      for (int k = 0; k < model->nq; ++k) qpos(f, k) = q[at(k)];
      break;
    }
    if (progress && (f % 64 == 0 || f + 1 == frames)) progress((f + 1.0) / frames);
  }
  st.ik_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_ik).count();

  // Statistics from MuJoCo's kinematics of the output.
  st.frames = frames;
  st.scale = scale;
  st.bvh_leg_m = bvh_leg;
  st.character_leg_m = char_leg;
  st.mean_ik_iterations = frames > st.unsolved_frames
                              ? static_cast<double>(iterations) / (frames - st.unsolved_frames)
                              : 0.0;
  const int pelvis_body = model.id(mjOBJ_BODY, "pelvis");
  std::vector<Eigen::Matrix3Xd> sole_actual(at(frames), Eigen::Matrix3Xd::Zero(3, 2 * kSoles));
  double sum_sq = 0.0;
  long n_err = 0;
  Vector3d pelvis_first = Vector3d::Zero(), pelvis_last = Vector3d::Zero();
  bool first_seen = false;
  for (int f = 0; f < frames; ++f) {
    if (!qpos.row(f).allFinite()) continue;
    for (int k = 0; k < model->nq; ++k) data->qpos[k] = qpos(f, k);
    mj_kinematics(model.get(), data.get());
    const Vector3d pel(data->xpos + 3 * pelvis_body);
    if (!first_seen) pelvis_first = pel;
    first_seen = true;
    pelvis_last = pel;
    for (int l = 0; l < n_kp + 2 * kSoles; ++l) {
      const Vector3d x(data->site_xpos + 3 * site_of_label[at(l)]);
      if (l >= n_kp) {
        sole_actual[at(f)].col(l - n_kp) = x;
        continue;
      }
      const double e = (x - result.targets.positions_m.row(f).segment<3>(3 * l).transpose()).norm();
      sum_sq += e * e;
      ++n_err;
      if (e > st.keypoint_max_m) {
        st.keypoint_max_m = e;
        st.keypoint_max_name = labels[at(l)].substr(3);
        st.keypoint_max_frame = f;
      }
    }
    for (int g = 0; g < model->ngeom; ++g) {
      if (model->geom_bodyid[g] == 0) continue;  // the floor
      const double low = geom_lowest_z(*model, *data, g);
      if (-low > st.max_penetration_m) {
        st.max_penetration_m = -low;
        st.penetration_frame = f;
        const char* name = mj_id2name(model.get(), mjOBJ_GEOM, g);
        st.penetration_geom = name ? name : "geom" + std::to_string(g);
      }
    }
  }
  st.keypoint_rms_m = n_err > 0 ? std::sqrt(sum_sq / static_cast<double>(n_err)) : 0.0;
  st.character_travel_m =
      std::hypot(pelvis_last.x() - pelvis_first.x(), pelvis_last.y() - pelvis_first.y());
  const Vector3d b0 = cap.position(pelvis, 0), b1 = cap.position(pelvis, frames - 1);
  st.bvh_travel_m = std::hypot(b1.x() - b0.x(), b1.y() - b0.y());

  // Contacts and stances, with the slide of the character's sole points over their contacts.
  for (int s = 0; s < 2; ++s) {
    std::vector<std::pair<Interval, int>> all;  // interval, sole point
    for (int p = 0; p < kSoles; ++p) {
      for (const Interval& i : feet[at(s)].contacts[at(p)]) {
        result.contacts.push_back({kSides[s][0], Sole::kNames[p], i.first, i.second});
        all.push_back({i, p});
      }
    }
    std::sort(all.begin(), all.end());
    std::vector<StanceStep> steps;
    for (const auto& [i, p] : all) {
      if (steps.empty() || i.first > steps.back().last_frame + 1) {
        StanceStep step;
        step.side = kSides[s][0];
        step.first_frame = i.first;
        step.last_frame = i.second;
        steps.push_back(step);
      }
      StanceStep& step = steps.back();
      step.last_frame = std::max(step.last_frame, i.second);
      const int col = s * kSoles + p;
      bool started = false;
      Vector3d start = Vector3d::Zero();  // where the point stood at its first solved frame
      for (int f = i.first; f <= i.second; ++f) {
        if (!qpos.row(f).allFinite()) continue;
        const Vector3d x = sole_actual[at(f)].col(col);
        if (!started) start = x;
        started = true;
        const double slide = std::hypot(x.x() - start.x(), x.y() - start.y());
        if (slide > step.slide_m) {
          step.slide_m = slide;
          step.slide_frame = f;
        }
        step.height_error_m = std::max(step.height_error_m, std::abs(x.z()));
      }
    }
    result.steps.insert(result.steps.end(), steps.begin(), steps.end());
  }
  // Why a step slid: the leg's joints held on a limit at its worst frame (the capture's pose is
  // beyond the character's range of motion there, so no IK solution keeps the sole still).
  for (StanceStep& step : result.steps) {
    if (step.slide_frame < 0) continue;
    for (int k = 0; k < model->nq; ++k) data->qpos[k] = qpos(step.slide_frame, k);
    step.joints_at_limit = leg_joints_at_limit(*model, data->qpos, step.side);
  }
  std::sort(result.steps.begin(), result.steps.end(),
            [](const StanceStep& a, const StanceStep& b) { return a.first_frame < b.first_frame; });
  for (const StanceStep& step : result.steps) st.max_slide_m = std::max(st.max_slide_m, step.slide_m);

  // Outputs.
  result.motion.columns = qpos_names(*model);
  result.motion.qpos = qpos;
  for (int f = 0; f < frames; ++f) result.motion.times_s.push_back(f * dt);
  result.motion.comments = {
      " biodyn retarget of " + options.source + " (joint map " + map.name + ")",
      " character: " + std::string(models::to_string(spec.sex)) + ", " +
          std::to_string(spec.height_m) + " m, " + std::to_string(spec.mass_kg) + " kg, " +
          models::to_string(spec.detail) + " detail",
      " scale (leg length ratio): " + std::to_string(scale)};
  result.bvh = character_bvh(character, *model, qpos, dt, options.output_units);
  st.total_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return result;
}

}  // namespace biodyn::mocap_io
