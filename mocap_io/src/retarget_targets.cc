// Retargeting (retarget_internal.h): the capture read onto the character's proportions. Each
// keypoint's free target is its parent's plus the character's bone along the capture's bone;
// the root moves as the capture's, scaled by the leg-length ratio; the feet get frames from
// the capture's foot bones, "flat" measured on the capture itself.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>

#include "biodyn/sim/errors.h"
#include "retarget_internal.h"

namespace biodyn::mocap_io::retarget_internal {
namespace {

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
/// s: frame times accepted (10 kHz to one frame per 10 s); windows counted in frames stay in
/// int range.
constexpr double kMinFrameTime_s = 1e-4;
constexpr double kMaxFrameTime_s = 10.0;
/// m: a capture reaching further from the origin has the wrong units (no lab is 10 km wide);
/// squared lengths of such values would overflow.
constexpr double kMaxCaptureExtent_m = 1e4;

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
  for (const models::Segment& s : c.segments)
    add(s.name + "_end", segment_end_W(s), s.name, s.name);
  return kps;
}

int keypoint_index(const std::vector<Keypoint>& kps, const std::string& name) {
  for (size_t i = 0; i < kps.size(); ++i) {
    if (kps[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

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

/// s, the BVH's frame time. Throws sim::InvalidArgument naming `source` for no frames or a
/// frame time out of [kMinFrameTime_s, kMaxFrameTime_s].
double checked_frame_time(const BvhMotion& motion, const std::string& source) {
  if (motion.frame_count() < 1) throw InvalidArgument(source + ": the BVH has no frames");
  if (!(motion.frame_time_s > 0)) {
    throw InvalidArgument(source + ": frame time must be > 0 s, got " +
                          std::to_string(motion.frame_time_s));
  }
  const double dt = motion.frame_time_s;
  // Contact windows and fades are counted in frames: a frame time outside what capture systems
  // record (10 kHz to one frame per 10 s) would overflow or empty them.
  if (dt < kMinFrameTime_s || dt > kMaxFrameTime_s) {
    throw InvalidArgument(source + ": frame time must be within [" +
                          std::to_string(kMinFrameTime_s) + ", " + std::to_string(kMaxFrameTime_s) +
                          "] s, got " + std::to_string(dt));
  }
  return dt;
}

/// On one flat foot of the capture (ankle a, MTP m, toe tip e if mapped; r_wa the ankle
/// joint's rotation): the bone's pitch, the toe bone's angle on it and the level axis across
/// it in the ankle joint's frame, added to what the frames before gave.
struct FlatFootSamples {
  std::vector<double> foot_pitches, toe_angles;
  Vector3d lateral_A = Vector3d::Zero();

  void add(const Vector3d& a, const Vector3d& m, const Vector3d* e, const Matrix3d& r_wa) {
    const Vector3d x = (m - a).normalized();
    const Vector3d y = Vector3d::UnitZ().cross(x).normalized();
    foot_pitches.push_back(pitch(x));
    if (e) toe_angles.push_back(angle_about(x, *e - m, y));
    lateral_A += r_wa.transpose() * y;
  }
};

/// Frame f's keypoint targets into `t` (3 x keypoints), each from its parent's on the
/// character's proportions; the toes are left to the feet (free_foot).
void place_keypoints(const RetargetInput& in, const Placement& pl, int f, Eigen::Matrix3Xd* t) {
  const Capture& cap = in.cap;
  const int nk = static_cast<int>(in.kps.size());
  for (int i = 0; i < nk; ++i) {
    const Keypoint& k = in.kps[at(i)];
    if (k.parent < 0) {
      t->col(i) = pl.r_align * pl.root_position(cap, f) + pl.t_align;
      continue;
    }
    if (k.name.rfind("toes_", 0) == 0) continue;  // from the foot, below
    const Keypoint& p = in.kps[at(k.parent)];
    const Vector3d rest_offset = k.o_W - p.o_W;
    const Vector3d bone = pl.r_align * (cap.position(k, f) - cap.position(p, f));
    if (k.map.rigid || bone.norm() < kMinBoneLength_m) {
      t->col(i) =
          t->col(k.parent) + pl.r_align * cap.from_rest(p.frame_joint, f) * pl.r_face * rest_offset;
    } else {
      t->col(i) = t->col(k.parent) + rest_offset.norm() * bone.normalized();
    }
  }
}

/// Frame f of one foot's free motion: its frame from the capture's ankle -> MTP bone, the
/// toes' angle, the ankle at its keypoint target (`t`) and the sole points. `across` carries
/// the axis across the foot bone from frame to frame.
void free_foot(const RetargetInput& in, const Placement& pl, const FootCalibration& calibration,
               int f, const Eigen::Matrix3Xd& t, Vector3d* across, FootTrack* foot) {
  const Capture& cap = in.cap;
  const Vector3d bvh_m = cap.position(in.kps[at(calibration.mtp)], f);
  const Vector3d foot_bone = pl.r_align * (bvh_m - cap.position(in.kps[at(calibration.ankle)], f));
  // The bone's frame (x along it, y across it), turned back by the flat pitch: the
  // character's foot is flat when the capture's bone has its flat pitch.
  const Vector3d x = foot_bone.normalized();
  const Matrix3d& r_wa =
      cap.poses[at(f)].rotations_W[at(in.kps[at(calibration.ankle)].frame_joint)];
  const Vector3d y = across_axis(x, pl.r_align * r_wa * calibration.flat_lateral_A, *across);
  *across = y;
  Matrix3d r_bone;
  r_bone << x, y, x.cross(y);
  foot->r_free[at(f)] = r_bone * rot_y(calibration.flat_pitch);
  foot->toe[at(f)] = 0.0;
  if (calibration.tip >= 0) {
    const Vector3d toe_bone = pl.r_align * (cap.position(in.kps[at(calibration.tip)], f) - bvh_m);
    foot->toe[at(f)] = angle_about(x, toe_bone, y) - calibration.flat_toe_pitch;
  }
  foot->ankle[at(f)] = t.col(calibration.ankle);
  foot->free[at(f)] = foot->free_points(f, 0.0);
}

}  // namespace

const Keypoint& RetargetInput::keypoint(const std::string& name) const {
  const int i = keypoint_index(kps, name);
  if (i < 0) {
    throw InvalidArgument(source + ": joint map '" + map_name + "' places no keypoint '" + name +
                          "' on this character");
  }
  return kps[at(i)];
}

RetargetInput read_input(const BvhMotion& motion, const JointMap& map, const JointMap& resolved,
                         const models::CharacterSpec& spec, const BvhUnits& units,
                         const std::string& source) {
  RetargetInput in;
  in.source = source;
  in.map_name = map.name;
  in.dt = checked_frame_time(motion, source);
  in.frames = motion.frame_count();
  // The character's geometry (its markers are replaced later; they move nothing).
  models::CharacterSpec plain_spec = spec;
  plain_spec.markers.clear();
  in.plain = models::generate_character(plain_spec);
  in.kps = character_keypoints(in.plain, resolved, motion);
  in.cap = sample(motion, units);
  for (int f = 0; f < in.frames; ++f) {
    const auto& p = in.cap.poses[at(f)].positions_W;
    if (!p.allFinite() || p.cwiseAbs().maxCoeff() > kMaxCaptureExtent_m) {
      throw InvalidArgument(
          source + ": frame " + std::to_string(f) + " has joint positions not finite or beyond " +
          std::to_string(kMaxCaptureExtent_m) + " m of the origin (metres per unit " +
          std::to_string(units.metres_per_unit) + ")");
    }
  }
  return in;
}

LegScale measure_legs(const RetargetInput& in, const ContactOptions& contacts) {
  // The BVH's ankle and MTP joints' contacts (heel and ball on the floor) tell where the
  // stance level is and which frames have the foot flat.
  const Capture& cap = in.cap;
  LegScale legs;
  for (int s = 0; s < 2; ++s) {
    const std::string sd = kSides[s];
    const Keypoint &hip = in.keypoint("thigh_" + sd), &knee = in.keypoint("shank_" + sd),
                   &ankle = in.keypoint("foot_" + sd), &mtp = in.keypoint("toes_" + sd);
    // Every leg bone needs a length: a direction is taken from each (a map that puts two
    // keypoints on one joint would give a foot frame that is not a rotation).
    const std::array<std::pair<const Keypoint*, const Keypoint*>, 3> bones = {
        {{&hip, &knee}, {&knee, &ankle}, {&ankle, &mtp}}};
    for (const auto& [from, to] : bones) {
      const double length = (cap.rest_position(*from) - cap.rest_position(*to)).norm();
      if (!(length > kMinBoneLength_m)) {
        throw InvalidArgument(in.source + ": joint map '" + in.map_name + "': keypoints " +
                              from->name + " and " + to->name +
                              " are at the same place in the BVH's rest pose (bone length " +
                              std::to_string(length) + " m); map them to different joints");
      }
    }
    legs.bvh_leg_m += 0.5 * ((cap.position(hip, 0) - cap.position(knee, 0)).norm() +
                             (cap.position(knee, 0) - cap.position(ankle, 0)).norm());
    legs.character_leg_m +=
        0.5 * (in.plain.find("thigh_" + sd)->length_m + in.plain.find("shank_" + sd)->length_m);
    legs.character_ankle_m += 0.5 * in.plain.find("foot_" + sd)->origin_W.z();
    std::vector<Vector3d> a, m;
    for (int f = 0; f < in.frames; ++f) {
      a.push_back(cap.position(ankle, f));
      m.push_back(cap.position(mtp, f));
    }
    double heel_level = 0.0, ball_level = 0.0;
    legs.heel[at(s)] = detect_point(a, in.dt, contacts, &heel_level);
    legs.ball[at(s)] = detect_point(m, in.dt, contacts, &ball_level);
    legs.bvh_ankle_level_m += 0.5 * heel_level;
  }
  if (!(legs.bvh_leg_m > kMinBoneLength_m)) {
    throw InvalidArgument(in.source +
                          ": the BVH's legs (hip-knee + knee-ankle) have zero "
                          "length; check the joint map");
  }
  legs.scale = legs.character_leg_m / legs.bvh_leg_m;
  return legs;
}

Placement place_capture(const RetargetInput& in, const LegScale& legs, bool align_start) {
  const Capture& cap = in.cap;
  Placement pl;
  // Facing: the BVH's rest pose faces left x up; the character's rest faces +x.
  const Vector3d rest_left =
      cap.rest_position(in.keypoint("thigh_l")) - cap.rest_position(in.keypoint("thigh_r"));
  pl.r_face = rot_z(heading(Vector3d(rest_left.y(), -rest_left.x(), 0.0)));
  pl.pelvis = &in.keypoint("pelvis");
  pl.scale = legs.scale;
  pl.bvh_ankle_level_m = legs.bvh_ankle_level_m;
  pl.character_ankle_m = legs.character_ankle_m;
  if (align_start) {
    pl.r_align =
        rot_z(-heading(cap.from_rest(pl.pelvis->frame_joint, 0) * pl.r_face * Vector3d::UnitX()));
    const Vector3d p0 = pl.r_align * pl.root_position(cap, 0);
    pl.t_align = Vector3d(-p0.x(), -p0.y(), 0.0);
  }
  return pl;
}

FootCalibration calibrate_foot(const RetargetInput& in, const LegScale& legs, int s) {
  // "Flat" is measured on the capture's own flat-foot frames (the rest pose if there are too
  // few), so rigs whose joints sit at other heights in the foot, or whose rest pose pitches the
  // foot, still land the sole flat. The lateral axis is used where the bone is steep.
  const Capture& cap = in.cap;
  const std::string sd = kSides[s];
  FootCalibration foot;
  foot.ankle = keypoint_index(in.kps, "foot_" + sd);
  foot.mtp = keypoint_index(in.kps, "toes_" + sd);
  foot.tip = keypoint_index(in.kps, "toes_" + sd + "_end");
  const Keypoint& ankle = in.keypoint("foot_" + sd);
  const Keypoint& mtp = in.keypoint("toes_" + sd);
  const Keypoint* tip = foot.tip >= 0 ? &in.kps[at(foot.tip)] : nullptr;
  const std::vector<bool> heel_on = flags(legs.heel[at(s)], in.frames);
  const std::vector<bool> ball_on = flags(legs.ball[at(s)], in.frames);
  FlatFootSamples flat;
  for (int f = 0; f < in.frames; ++f) {
    if (!heel_on[at(f)] || !ball_on[at(f)]) continue;
    const Vector3d e = tip ? cap.position(*tip, f) : Vector3d::Zero();
    flat.add(cap.position(ankle, f), cap.position(mtp, f), tip ? &e : nullptr,
             cap.poses[at(f)].rotations_W[at(ankle.frame_joint)]);
  }
  if (static_cast<int>(flat.foot_pitches.size()) < kMinFlatFrames) {
    flat = FlatFootSamples{};
    const Vector3d e = tip ? cap.rest_position(*tip) : Vector3d::Zero();
    flat.add(cap.rest_position(ankle), cap.rest_position(mtp), tip ? &e : nullptr,
             cap.rest.rotations_W[at(ankle.frame_joint)]);
  }
  foot.flat_pitch = median(flat.foot_pitches);
  foot.flat_toe_pitch = tip ? median(flat.toe_angles) : 0.0;
  foot.flat_lateral_A = flat.lateral_A.normalized();
  return foot;
}

FootTrack start_foot_track(const RetargetInput& in, const FootCalibration& foot, int s) {
  FootTrack t;
  t.sole = sole_of(in.plain, kSides[s]);
  t.ankle_to_mtp_W = in.kps[at(foot.mtp)].o_W - in.kps[at(foot.ankle)].o_W;
  t.r_free.resize(at(in.frames));
  t.toe.resize(at(in.frames));
  t.ankle.resize(at(in.frames));
  t.free.resize(at(in.frames));
  return t;
}

std::vector<Eigen::Matrix3Xd> free_targets(const RetargetInput& in, const Placement& placement,
                                           const std::array<FootCalibration, 2>& calibration,
                                           std::array<FootTrack, 2>* feet) {
  const int nk = static_cast<int>(in.kps.size());
  std::vector<Eigen::Matrix3Xd> kp_target(at(in.frames), Eigen::Matrix3Xd(3, nk));
  std::array<Vector3d, 2> across;  // the axis across each foot bone at the frame before
  across.fill(placement.r_align * placement.r_face * Vector3d::UnitY());
  for (int f = 0; f < in.frames; ++f) {
    place_keypoints(in, placement, f, &kp_target[at(f)]);
    for (int s = 0; s < 2; ++s) {
      free_foot(in, placement, calibration[at(s)], f, kp_target[at(f)], &across[at(s)],
                &(*feet)[at(s)]);
    }
  }
  return kp_target;
}

}  // namespace biodyn::mocap_io::retarget_internal
