#pragma once
/// Gait analysis of a walk, simulated or captured (issue 28): each foot's contact (from its
/// ground force when known, else from the sole's height), gait cycles from a heel strike to the
/// next strike of the same foot, the sagittal joint angles' mean cycle, the cycle's timing and
/// the figures human walking is judged by, beside normative adult walking
/// (models::normative_gait(); references.md, "Normative adult walking").

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <array>
#include <limits>
#include <string>
#include <vector>

namespace biodyn::scenarios {

struct RecordedMotion;

/// Points of a mean cycle: every 1 % from 0 to 100 %.
inline constexpr int kGaitCyclePoints = 101;
/// N: a foot is on the floor while its vertical ground force is above this.
inline constexpr double kFootLoaded_N = 20;
/// s: without forces, a heel strike is where the heel is furthest ahead of the pelvis within this
/// time on either side, a toe off where the toe is furthest behind (Zeni et al. 2008).
inline constexpr double kEventWindow_s = 0.25;
/// s: such an extremum needs this much of the motion on either side (at an end it may lie
/// outside the motion).
inline constexpr double kEventEdge_s = 0.05;
/// s: contact runs and gaps shorter than this are noise (a heel bounce, a force spike).
inline constexpr double kContactDebounce_s = 0.04;
/// The analysed cycles: a cycle shorter or longer than these fractions of the median is a
/// start, a stop or a stumble, not steady walking, and is left out (and counted).
inline constexpr double kCycleMinOfMedian = 0.7, kCycleMaxOfMedian = 1.4;

/// The joints of a mean cycle, in column order.
enum GaitJoint { kGaitHip = 0, kGaitKnee = 1, kGaitAnkle = 2 };
inline constexpr const char* kGaitJointNames[3] = {"hip_flexion", "knee_flexion",
                                                   "ankle_dorsiflexion"};

struct GaitInput {
  const mjModel* model = nullptr;  ///< the character the motion is of (a generated one)
  std::vector<double> times_s;     ///< s, increasing
  Eigen::MatrixXd qpos;            ///< frames x nq
  /// frames x 2 (left, right): each foot's vertical ground force, N; empty: events from the
  /// heel and toe relative to the pelvis (kEventWindow_s).
  Eigen::MatrixXd foot_force_N;
  /// s: only cycles within [from_s, to_s] are analysed (skip a start-up, a stop).
  double from_s = 0, to_s = std::numeric_limits<double>::infinity();
};

/// One judged figure with its human band (the issue's; references.md).
struct GaitFigure {
  std::string name, unit, source;
  double value = 0;
  double lo = 0, hi = 0;  ///< the band; value within it is human-like
  bool met() const { return value >= lo && value <= hi; }
};

struct GaitAnalysis {
  std::string events;       ///< "ground force" or "heel and toe vs pelvis (Zeni 2008)"
  int cycles = 0;           ///< analysed, both feet together
  int cycles_left_out = 0;  ///< outside kCycleMinOfMedian..kCycleMaxOfMedian of the median
  double cycle_s = 0;       ///< mean stride time
  double cadence_steps_per_min = 0, speed_m_s = 0, stride_length_m = 0;
  double stance_percent = 0, double_support_percent = 0;
  /// m: the CoM's vertical range per step (strike to the other foot's strike), mean; NaN
  /// without two strikes in a row.
  double com_excursion_m = 0;
  /// deg: the trunk's (thorax's) lean from vertical along the walking direction (+ forward),
  /// mean and the largest magnitude over the analysed cycles.
  double trunk_lean_mean_deg = 0, trunk_lean_max_deg = 0;
  double knee_midstance_deg = 0;                ///< at the middle of single support
  double knee_loading_peak_deg = 0;             ///< largest from the strike to mid-stance
  double knee_swing_peak_deg = 0;               ///< largest from toe off to the next strike
  double hip_range_deg = 0;                     ///< per cycle, largest - smallest hip flexion
  double ankle_plantarflexion_toe_off_deg = 0;  ///< -dorsiflexion at toe off
  /// kGaitCyclePoints x 3 (GaitJoint), deg: mean and SD over the analysed cycles of both feet.
  Eigen::MatrixXd mean_deg, sd_deg;
  std::array<double, 3> correlation{};  ///< Pearson r of each mean curve with the normative one
  std::array<double, 3> rms_from_normative_deg{};
  /// The judged figures: the bands first, then reported ones.
  std::vector<GaitFigure> figures;
  bool all_met() const;  ///< every judged figure within its band (false without cycles)
};

/// The normative curves at kGaitCyclePoints (models/data/normative_gait.csv, interpolated by a
/// periodic cubic through its key values): mean and SD, kGaitCyclePoints x 3, deg.
void normative_gait_curves(Eigen::MatrixXd* mean_deg, Eigen::MatrixXd* sd_deg);

/// A recorded simulated walk (motion_recorder.h) as the analysis's input: its poses, and each
/// foot's vertical ground force for the events; cycles from `from_s`.
GaitInput gait_input(const mjModel& m, const RecordedMotion& rec, double from_s);

/// Analyses `in`. Throws sim::InvalidArgument naming what is wrong (sizes, a model without
/// legs, no complete cycle within the range).
GaitAnalysis analyse_gait(const GaitInput& in);

}  // namespace biodyn::scenarios
