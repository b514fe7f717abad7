#pragma once
/// The character generator: a standing humanoid built from anthropometric tables
/// (de Leva 1996 masses, CoM and radii of gyration; segment lengths as ratios of height), with
/// anatomical joint ranges, one torque actuator per DOF and the thesis's marker sites.
///
/// Frames: the character stands at the origin facing +x, y to its left, z up. Every body frame
/// is parallel to the world frame in the standing pose and has its origin at the joint that
/// connects it to its parent (the pelvis: midpoint of the hip joint centres).

#include <Eigen/Core>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "biodyn/models/muscle_anatomy.h"

namespace biodyn::models {

enum class Sex { kMale, kFemale };
/// kGait: the paper's lower-body model (pelvis root, trunk, thighs, shanks, feet, toes).
/// kFull: adds the spine in two segments, neck, head, shoulder girdles, arms, forearms, hands.
enum class Detail { kGait, kFull };

/// Measured values that replace the tables for one segment (or both sides: "thigh").
struct SegmentOverride {
  std::optional<double> mass_kg;   ///< kg, > 0; the other segments share the remaining mass
  std::optional<double> length_m;  ///< m, > 0; scales the segment's geometry and inertia
  /// m, pelvis only: distance between the hip joint centres (default: hip_joint_separation of
  /// body_proportions.csv times height), in (0, 0.6)
  std::optional<double> width_m;
};

/// Where a marker sits on the skin, relative to its part's geometry, so it scales with the body
/// (markers_26.csv explains the terms): position = proximal joint + along * (axis to the distal
/// end) + ant/lat/sup * the part's surface half-extent (lat mirrored: + is away from the
/// midline). For the foot, along runs heel -> toe tip and sup sole (0) -> dorsum (1). Or, with
/// position_B, a fixed offset in the body frame of the segment carrying the part.
struct MarkerPlacement {
  std::string name;  ///< e.g. "LASI"
  /// A full-detail part: pelvis, lumbar, thorax, neck, head, clavicle_l, upper_arm_l,
  /// forearm_l, hand_l, thigh_l, shank_l, foot_l, toes_l (and _r).
  std::string part;
  double along = 0.0, ant = 0.0, lat = 0.0, sup = 0.0;  ///< fractions (see above)
  std::optional<Eigen::Vector3d> position_B;  ///< m, body frame: replaces the fractions if set
  std::string description;
};

/// What to generate. Defaults: the default character of `biodyn model` and `./run.sh`.
struct CharacterSpec {
  double height_m = 1.80;  ///< m, standing height (vertex to sole), in [kMinHeight, kMaxHeight]
  double mass_kg = 80.0;   ///< kg, total body mass, in [kMinMass, kMaxMass]
  Sex sex = Sex::kMale;
  Detail detail = Detail::kFull;
  /// Keyed by segment name ("thigh_l") or by name without side ("thigh": both sides).
  std::map<std::string, SegmentOverride> overrides;
  /// Marker sites to place; empty: the thesis's 26 markers (markers_26.csv). A marker on an arm
  /// part is left out of the gait detail (it has no arms).
  std::vector<MarkerPlacement> markers;
  /// Add the Hill muscles of the legs (muscle_anatomy.h): sites, wrapping cylinders and one
  /// spatial tendon per muscle in the MJCF. Mass, joints and geometry are the same either way.
  bool muscles = false;
  /// Multiplies every joint's tau_max (the paper's scaling by mass and height times this): 1
  /// by default; `biodyn evaluate`'s fixed rule keeps a reference body's torques on another
  /// body with it. In (0, 10].
  double tau_max_factor = 1.0;

  static constexpr double kMinHeight = 0.5;  ///< m; below: not a standing human
  static constexpr double kMaxHeight = 2.8;  ///< m; taller than any recorded human
  static constexpr double kMinMass = 10.0;   ///< kg
  static constexpr double kMaxMass = 400.0;  ///< kg

  /// Throws sim::InvalidArgument naming the field, the rule and the value.
  void validate() const;
};

enum class JointType { kHinge, kBall };

/// One joint of a segment (a hinge is 1 DOF, a ball 3 DOF).
struct Joint {
  std::string name;  ///< e.g. "knee_flexion_l", "hip_l"
  JointType type = JointType::kHinge;
  Eigen::Vector3d anchor_B = Eigen::Vector3d::Zero();  ///< m, in the segment's body frame
  Eigen::Vector3d axis_B = Eigen::Vector3d::UnitY();   ///< hinge axis (unit), body frame
  double min_rad = 0.0;                                ///< hinge: lower limit; ball: 0
  double max_rad = 0.0;   ///< hinge: upper limit; ball: cone half-angle on total rotation
  double armature = 0.0;  ///< kg m^2
  double damping = 0.0;   ///< N m s / rad
  /// N m, torque limit per actuated axis (hinge: [0]; ball: x, y, z of the body frame),
  /// the paper's Table 2 value scaled by torque_scale(): see CharacterSpec docs in README.
  Eigen::Vector3d tau_max_Nm = Eigen::Vector3d::Zero();
  std::string tau_source;  ///< "paper" or "estimate"
};

enum class GeomType { kBox, kCapsule, kSphere };

/// A collision geom, in the segment's body frame.
struct Geom {
  GeomType type = GeomType::kBox;
  Eigen::Vector3d center_B = Eigen::Vector3d::Zero();      ///< m (box, sphere)
  Eigen::Vector3d half_extents = Eigen::Vector3d::Zero();  ///< m (box)
  Eigen::Vector3d from_B = Eigen::Vector3d::Zero(),
                  to_B = Eigen::Vector3d::Zero();  ///< m (capsule)
  double radius = 0.0;                             ///< m (capsule, sphere)
};

/// One rigid body of the character.
struct Segment {
  std::string name;                                    ///< e.g. "pelvis", "thigh_l"
  std::string parent;                                  ///< empty for the root (pelvis)
  Eigen::Vector3d origin_W = Eigen::Vector3d::Zero();  ///< m, body origin in the standing pose
  double mass_kg = 0.0;
  double length_m = 0.0;  ///< m, proximal joint to distal landmark (foot: heel to MTP joint)
  Eigen::Vector3d com_B = Eigen::Vector3d::Zero();      ///< m, body frame
  Eigen::Matrix3d inertia_B = Eigen::Matrix3d::Zero();  ///< kg m^2, about the CoM, body axes
  double table_mass_fraction = 0.0;  ///< the tables' share of body mass (before overrides)
  std::string table_parts;           ///< which table rows make it up, for the summary
  std::vector<Joint> joints;         ///< empty for the root (it gets a free joint)
  std::vector<Geom> geoms;
};

/// A marker site on a segment (the thesis's 26-marker skeleton-marker model).
struct Marker {
  std::string name;                                      ///< e.g. "LASI"
  std::string segment;                                   ///< body it rides on
  Eigen::Vector3d position_B = Eigen::Vector3d::Zero();  ///< m, body frame
  std::string description;
};

/// A generated character: everything the MJCF writer and the summary need.
struct Character {
  CharacterSpec spec;
  std::vector<Segment> segments;  ///< parents before children; segments[0] is the root
  std::vector<Marker> markers;
  std::vector<MuscleDefinition> muscles;  ///< empty unless spec.muscles
  double torque_scale = 1.0;              ///< (mass/82.2 kg) * (height/1.799 m), paper §5.1
  double standing_height_m = 0.0;         ///< highest geom point in the standing pose
  double lowest_point_m = 0.0;            ///< lowest geom point (the soles), 0 by construction

  double total_mass_kg() const;
  int actuated_dof_count() const;
  const Segment* find(const std::string& name) const;
};

/// The paper's torque scale of a body (§5.1): (mass / 82.2 kg) x (height / 1.799 m) x
/// spec.tau_max_factor. Every joint's tau_max is its Table 2 value times this.
double torque_scale(const CharacterSpec& spec);

/// Reference subject of the paper's Table 1/2: torques scale from these (paper §5.1).
inline constexpr double kPaperHeight_m = 1.799;
inline constexpr double kPaperMass_kg = 82.2;

/// Builds the character. Throws sim::InvalidArgument on a bad spec or override (naming the
/// segment, field and value), or sim::Error if an embedded table is malformed.
Character generate_character(const CharacterSpec& spec);

/// Checks that every override key names a segment of `detail` (or one without its _l/_r side).
/// Throws InvalidArgument starting with `source` (e.g. the overrides file) and listing the names.
void check_override_names(const std::map<std::string, SegmentOverride>& overrides, Detail detail,
                          const std::string& source);

/// Parses "male"/"female" and "gait"/"full"; throws InvalidArgument naming `field` and value.
Sex parse_sex(const std::string& text, const std::string& field = "sex");
Detail parse_detail(const std::string& text, const std::string& field = "detail");
const char* to_string(Sex sex);
const char* to_string(Detail detail);

/// Reads segment overrides from JSON text: {"segments": {"thigh": {"mass_kg": 9.1,
/// "length_m": 0.45}}}. `source` names the file in errors. Throws InvalidArgument for malformed
/// JSON, unknown keys, non-numbers or non-positive values (segment names are checked by
/// generate_character, which knows the detail level).
std::map<std::string, SegmentOverride> parse_overrides(const std::string& json_text,
                                                       const std::string& source);

}  // namespace biodyn::models
