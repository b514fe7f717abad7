#pragma once
/// Ground reaction forces from kinematics alone, for motions without force plates (every BVH,
/// every retargeted body): the method of Fluit et al. 2014 and Skals et al. 2017, as AnyBody's
/// AMMR implements it (Tools/GRFPrediction), solved per frame as a small box QP.
///
/// Each sole carries contact points (heel, midfoot edges, metatarsal heads on the foot; the toe
/// tip on the toes). A point can push only when it is near the floor and slow: its strength is
/// ramped down linearly from 0.8 h_max to h_max above the floor and from 0.15 v_max to v_max
/// of speed (AMMR's linear profile: h_max 0.04 m, v_max 0.8 m/s), the speed not counting for
/// a point at or below its floor (it touches: a striking heel may slide). Its force lies in a
/// linear friction pyramid (4 edges, mu 0.5): unilateral, within the cone. Per frame the point
/// forces minimise
///   w_root |root residual force and moment|^2   (what the ground must supply, from ID)
/// + w_joint |leg joint torques / tau_max|^2      (Fluit: the ground takes load where it spares
///                                                the muscles; decides double support's split)
/// + w_effort |forces|^2 + w_smooth |forces - last frame's|^2,
/// each term in body-weight units. The QP is run forward and backward in time and the two
/// averaged, so the smoothing has no lag.
///
/// Assumptions a report must state: the floor is flat and level (each point's floor height is
/// its height while its foot stands flat, which absorbs a sole that an IK fit leaves pitched,
/// floating or sunk); the body's mass is the subject's (the estimate is
/// m (g + a) wherever the feet can supply it: a wrong mass biases it by the same fraction).

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

namespace biodyn::mocap_io {

struct GroundForceEstimateOptions {
  double contact_height_m = 0.04;  ///< h_max: a point this high above its floor cannot push
  double contact_speed_mps = 0.8;  ///< v_max: a point this fast cannot push
  double friction = 0.5;           ///< mu of the friction pyramid (AMMR's default)
  /// Strength of one contact point, in body weights (CusToM: 0.4 m g).
  double point_strength_bw = 0.4;
  double root_weight = 1e4;  ///< root residual, force / (m g) and moment / (m g leg)
  /// Leg joint torques over their tau_max (the motors' ranges). Small: on walking5 (plates),
  /// 0.001 / 0.01 / 0.03 / 0.1 gave vertical 6.6 / 7.0 / 7.7 / 8.9% body weight RMS and fore-aft
  /// 5.3 / 5.0 / 4.9 / 5.6%.
  double joint_weight = 0.01;
  double effort_weight = 1e-3;  ///< point forces / strength
  double smooth_weight = 0.3;   ///< change of point forces from the last frame / strength
  /// The motion's floor: this quantile of every sole point's height. Each point's own floor is
  /// its height while its foot stands flat and still (ground_force_estimate.cc).
  double floor_quantile = 0.02;
};

/// A contact point on a sole: on `body` (the foot or its toes), at `pos_B` in its frame.
struct SoleContactPoint {
  std::string name;  ///< e.g. "heel_medial_l"
  int side = 0;      ///< models::kLeft or models::kRight
  int body = -1;
  Eigen::Vector3d pos_B = Eigen::Vector3d::Zero();
};

/// The contact points of a generated character's soles (8 per foot: heel, midfoot and
/// metatarsal corners of the foot's box, the toe tip's corners on the toes). Throws
/// models::RigError when the model has no feet with soles.
std::vector<SoleContactPoint> sole_contact_points(const mjModel& m);

/// Per frame (frames rows), SI units, world frame.
struct GroundForceEstimate {
  std::vector<SoleContactPoint> points;
  std::vector<double> floor_z_m;                  ///< per point: its floor height
  std::array<Eigen::MatrixXd, 2> force_N;         ///< per side: frames x 3
  std::array<Eigen::MatrixXd, 2> cop_m;           ///< per side: frames x 3 (NaN when unloaded)
  std::array<Eigen::VectorXd, 2> free_moment_Nm;  ///< per side: vertical free moment
  Eigen::MatrixXd activation;                     ///< frames x points: each point's ramp, 0..1
  Eigen::MatrixXd height_m;                       ///< frames x points: above its floor
  Eigen::MatrixXd speed_mps;                      ///< frames x points
  Eigen::MatrixXd generalized_force;              ///< frames x nv: the forces' J^T f
};

/// Estimates the ground forces of a motion on `m` (contacts and constraints off, as inverse
/// dynamics runs it): `qpos` (frames x nq) and `qvel` (frames x nv) its filtered states,
/// `required` (frames x nv) the generalised forces each frame needs with no ground
/// (mj_inverse's qfrc_inverse). Deterministic. Offline (per motion, not per simulation step).
/// Throws sim::InvalidArgument for mismatched sizes, no frames or a massless model.
GroundForceEstimate estimate_ground_forces(const mjModel& m, const Eigen::MatrixXd& qpos,
                                           const Eigen::MatrixXd& qvel,
                                           const Eigen::MatrixXd& required,
                                           const GroundForceEstimateOptions& options = {});

}  // namespace biodyn::mocap_io
