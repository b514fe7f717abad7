#pragma once
/// MJCF for a generated character, built through tinyxml2's DOM (style.md, habit 10), and the
/// JSON summary `biodyn model --summary` writes.

#include <string>

#include "biodyn/models/character.h"

namespace biodyn::models {

/// Simulation settings written into <option>/<size>, chosen for stable humanoid contact in
/// MuJoCo 2.2.2 (mujoco-2.2.2.md, walking-notes.md).
/// Ground beside the floor plane (issue 28: slopes and steps), static boxes along +x (the
/// character starts facing +x) from start_m on, 4 m wide; every geom of the world body is
/// ground to the contact queries (sim/queries.h).
struct Terrain {
  enum class Kind {
    kFlat,
    /// A ramp up at slope_deg over ramp_m, a plateau of plateau_m, a ramp down as steep.
    kHill,
    /// A step up of step_m, a plateau of plateau_m, a step down as high.
    kSteps,
  };
  Kind kind = Kind::kFlat;
  double start_m = 6.0;
  double slope_deg = 5.0;
  double ramp_m = 4.0;
  double step_m = 0.05;
  double plateau_m = 3.0;
  /// m, the ground's height at x (world; 0 on the floor).
  double height_at(double x) const;
  double ramp_length_m() const;     ///< m along x of each ramp (0: steps, flat)
  double plateau_height_m() const;  ///< m (0: flat)
  void validate() const;            ///< throws sim::InvalidArgument naming the field
};
/// "flat" | "hill" | "steps"; throws sim::InvalidArgument naming `field` and the value.
Terrain::Kind parse_terrain_kind(const std::string& text, const std::string& field);

struct PhysicsOptions {
  double timestep_s = 0.002;  ///< s; 2 ms with armature ~0.1 was stable for a walker here
  /// Elliptic friction cones with impratio 5 reduce foot creep (mujoco-2.2.2.md).
  bool elliptic_cone = true;
  double impratio = 5.0;
  /// Sparse constraint Jacobians: Newton's Hessian factorisation then follows the kinematic
  /// tree. Same answers to rounding; measured on the full character walking 20 s at 1 m/s:
  /// 34x real time against 26x with dense rows (MuJoCo's "auto" picks dense below 60 DOF).
  bool sparse_jacobian = true;
  int solver_iterations = 50;
  double solver_tolerance = 1e-8;  ///< MuJoCo's default; Newton needs ~1.5 iterations here
  /// Static sizes (2.2.2 drops contacts past these with only a warning). Boxes give up to 4
  /// contacts each on a plane, capsules 2: a fallen full body touches with < 80 contacts; an
  /// elliptic condim-3 contact takes 3 rows, each weld 6, each limit 1.
  int nconmax = 200;
  int njmax = 1000;
  double friction = 1.0;  ///< sliding friction of every geom and the floor
  /// s, joint-limit solref time constant (written as at least 2 timesteps). MuJoCo's default 0.02
  /// lets a heavy body sink into its limits and store energy there that comes back later: measured
  /// on a 1.40 m / 150 kg drop, 40 J (3.5% of the start energy) at 0.02, 7.5 J (0.6%) at 0.005.
  double limit_time_constant_s = 0.005;
  /// s, solref time constant of the foot-contact welds (MuJoCo's default; written as at least
  /// 2 timesteps).
  double weld_time_constant_s = 0.02;
  /// The scene's ground beside the floor.
  Terrain terrain;
};

/// Names of the foot-contact weld equalities: "foot_weld_l", "foot_weld_r" (body1 = foot,
/// body2 = world, inactive in the file).
inline constexpr const char* kFootWeldPrefix = "foot_weld_";

/// The MJCF text of `c`: floor, light, tracking camera, one body per segment with an explicit
/// <inertial>, joints with limits/armature/damping, one <motor> per DOF (ctrl in N m, limited
/// to +-tau_max), collision geoms (body-floor only; no self-collision) and marker sites
/// named "marker_<NAME>", and one inactive foot weld per foot (kFootWeldPrefix).
std::string to_mjcf(const Character& c, const PhysicsOptions& options = {});

/// Actuator names of a joint: {name} for a hinge, {name_x, name_y, name_z} for a ball.
std::vector<std::string> actuator_names(const Joint& joint);

/// JSON text listing every segment (mass kg, length m, CoM m, inertia kg m^2, table fraction,
/// joints), the markers, total mass, standing height, DOF counts and the inputs.
std::string summary_json(const Character& c);

}  // namespace biodyn::models
