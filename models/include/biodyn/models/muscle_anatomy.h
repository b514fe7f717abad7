#pragma once
/// The character's muscles as anatomy: Hill muscle-tendon units' parameters and paths (origin,
/// via points, insertion, wrapping cylinders) on the generated segments, per leg:
/// gluteus maximus, gluteus medius (anterior and posterior parts), iliopsoas, rectus femoris,
/// vasti, hamstrings, biceps femoris short head, gastrocnemius, soleus, tibialis anterior,
/// extensor digitorum longus, adductor longus and brevis, adductor magnus, tibialis posterior,
/// peroneus, flexor digitorum longus, flexor hallucis longus (18 per leg). Each spans the joints
/// its path crosses (ext_dig and the two long toe flexors the toes too).
///
/// Source: Rajagopal et al. 2016 (models/data/muscles_rajagopal2016.json names the file and
/// every number's muscle compartment). Scaling to the generated body (README, "Muscles"):
///   - path points: from the model's OpenSim body frames (x anterior, y up, z right) to the
///     generated segments' frames (x forward, y left, z up), each segment's points scaled by the
///     ratio of its length to the model's (pelvis: hip-joint separation sideways, height ratio
///     otherwise; foot: ankle-to-toe-joint distance along, its height vertically);
///   - optimal fibre and tendon slack lengths by the ratio of the path's length to the model's in
///     the standing pose (straight segments between points), as OpenSim's scale tool does;
///   - F_max by body mass / 75.337 kg (the model's mass): muscle volume grows with mass x height
///     (Handsfield et al. 2014) and PCSA = volume / l_opt, with l_opt growing with height.
/// The physics of these units (curves, tendon, activation) is the muscles layer's.

#include <Eigen/Core>
#include <string>
#include <vector>

namespace biodyn::models {

struct Character;

/// A point of a muscle's path, fixed on a segment.
struct MusclePathPoint {
  std::string segment;                                   ///< e.g. "shank_l"
  Eigen::Vector3d position_B = Eigen::Vector3d::Zero();  ///< m, segment body frame
};

/// A wrapping cylinder the path goes around (MuJoCo spatial-tendon wrapping) between path
/// points after_point and after_point + 1, on the side of side_B.
struct MuscleWrapCylinder {
  std::string name;     ///< e.g. "KnExt_at_fem_l" (shared by muscles that wrap the same bone)
  std::string segment;  ///< body carrying it
  Eigen::Vector3d center_B = Eigen::Vector3d::Zero();  ///< m, body frame
  Eigen::Vector3d axis_B = Eigen::Vector3d::UnitY();   ///< unit, body frame
  double radius_m = 0, half_length_m = 0;
  Eigen::Vector3d side_B = Eigen::Vector3d::Zero();  ///< m, body frame: a point on the wrap side
  bool has_side = false;  ///< false: no side site (MuJoCo wraps the shorter way round)
  int after_point = 0;
};

/// One muscle-tendon unit of the generated character (parameters already scaled to the body).
struct MuscleDefinition {
  std::string name;       ///< e.g. "soleus_l": also the MJCF spatial tendon's name
  std::string base_name;  ///< e.g. "soleus"
  std::string description;
  std::string compartments;  ///< the model's compartments summed into F_max, e.g. "gasmed+gaslat"
  std::string parameters_from;  ///< the compartment giving lengths, pennation and path
  double max_isometric_force_N = 0;
  double optimal_fiber_length_m = 0;
  double tendon_slack_length_m = 0;
  double pennation_at_optimal_rad = 0;
  std::string tendon = "rigid";  ///< "rigid" or "compliant" (the default for this muscle)
  /// Passive fibre strain at which the passive force reaches F_max (the source model's).
  double passive_strain_at_fmax = 0.6;
  std::vector<MusclePathPoint> path;
  std::vector<MuscleWrapCylinder> wraps;
  /// m, path length in the standing pose (straight segments) here and in the source model;
  /// their ratio scaled the fibre and tendon lengths.
  double path_length_m = 0, source_path_length_m = 0;
};

/// The muscles of `c` (built from c.segments; needs the legs: both details have them).
/// Throws sim::Error if the embedded table is malformed.
std::vector<MuscleDefinition> generate_muscles(const Character& c);

/// Source of the table (the JSON's "source" text), for summaries.
std::string muscle_table_source();

/// Mass of the source model's subject, kg (F_max scales with mass / this).
inline constexpr double kMuscleModelMass_kg = 75.337;

}  // namespace biodyn::models
