// Retargeting a BVH to a generated character (retarget.h). Stages (retarget_internal.h): read
// the capture onto the character's proportions (keypoints and sole points: retarget_targets.cc);
// detect the sole points' contacts and pin them (retarget_contacts.cc); solve marker IK frame
// by frame (retarget_ik.cc); measure the result with MuJoCo's kinematics of the output (here).
#include "biodyn/mocap_io/retarget.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>

#include "biodyn/models/mjcf.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"
#include "retarget_internal.h"

namespace biodyn::mocap_io {
namespace {

using retarget_internal::add_ik_sites;
using retarget_internal::at;
using retarget_internal::calibrate_foot;
using retarget_internal::FootCalibration;
using retarget_internal::FootTrack;
using retarget_internal::free_targets;
using retarget_internal::IkSites;
using retarget_internal::IkSolution;
using retarget_internal::initial_targets;
using retarget_internal::Interval;
using retarget_internal::kSides;
using retarget_internal::kSoles;
using retarget_internal::LegScale;
using retarget_internal::measure_legs;
using retarget_internal::place_capture;
using retarget_internal::Placement;
using retarget_internal::plan_contacts;
using retarget_internal::read_input;
using retarget_internal::RetargetInput;
using retarget_internal::Sole;
using retarget_internal::solve_ik;
using retarget_internal::start_foot_track;
using retarget_internal::Vector3d;
using sim::InvalidArgument;

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
      const double angle =
          2.0 * std::atan2(std::sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]), std::abs(q[0]));
      at_limit = angle > hi - kAtLimit_rad;
    }
    const char* name = mj_id2name(&m, mjOBJ_JOINT, j);
    if (at_limit) out.push_back(name ? name : "joint" + std::to_string(j));
  }
  return out;
}

/// The IK site of each label.
std::vector<int> label_sites(const sim::Model& model, const std::vector<std::string>& labels) {
  std::vector<int> site_of_label(labels.size());
  for (size_t l = 0; l < labels.size(); ++l) {
    site_of_label[l] = model.id(mjOBJ_SITE, "marker_" + labels[l]);
  }
  return site_of_label;
}

/// The deepest geom below the floor at frame f (d at its pose), if deeper than st's so far.
void note_penetration(const mjModel& m, const mjData& d, int f, RetargetStats* st) {
  for (int g = 0; g < m.ngeom; ++g) {
    if (m.geom_bodyid[g] == 0) continue;  // the floor
    const double low = sim::geom_lowest_z(m, d, g);
    if (-low > st->max_penetration_m) {
      st->max_penetration_m = -low;
      st->penetration_frame = f;
      const char* name = mj_id2name(&m, mjOBJ_GEOM, g);
      st->penetration_geom = name ? name : "geom" + std::to_string(g);
    }
  }
}

/// From MuJoCo's kinematics of the output `qpos`: the keypoint errors against `targets`, the
/// penetration and the character's travel, into `st`. Returns the sole points' positions (3 x
/// 2 kSoles per frame, m, world; zero on unsolved frames).
std::vector<Eigen::Matrix3Xd> measure_output(const sim::Model& model, sim::Data* data,
                                             const std::vector<int>& site_of_label,
                                             const IkSites& sites, const Eigen::MatrixXd& qpos,
                                             const Eigen::MatrixXd& targets, RetargetStats* st) {
  const int frames = static_cast<int>(qpos.rows());
  const int n_kp = sites.n_kp;
  const int pelvis_body = model.id(mjOBJ_BODY, "pelvis");
  std::vector<Eigen::Matrix3Xd> sole_actual(at(frames), Eigen::Matrix3Xd::Zero(3, 2 * kSoles));
  double sum_sq = 0.0;
  long n_err = 0;
  Vector3d pelvis_first = Vector3d::Zero(), pelvis_last = Vector3d::Zero();
  bool first_seen = false;
  for (int f = 0; f < frames; ++f) {
    if (!qpos.row(f).allFinite()) continue;
    for (int k = 0; k < model->nq; ++k) (*data)->qpos[k] = qpos(f, k);
    mj_kinematics(model.get(), data->get());
    const Vector3d pel((*data)->xpos + 3 * pelvis_body);
    if (!first_seen) pelvis_first = pel;
    first_seen = true;
    pelvis_last = pel;
    for (int l = 0; l < n_kp + 2 * kSoles; ++l) {
      const Vector3d x((*data)->site_xpos + 3 * site_of_label[at(l)]);
      if (l >= n_kp) {
        sole_actual[at(f)].col(l - n_kp) = x;
        continue;
      }
      const double e = (x - targets.row(f).segment<3>(3 * l).transpose()).norm();
      sum_sq += e * e;
      ++n_err;
      if (e > st->keypoint_max_m) {
        st->keypoint_max_m = e;
        st->keypoint_max_name = sites.labels[at(l)].substr(3);
        st->keypoint_max_frame = f;
      }
    }
    note_penetration(*model, **data, f, st);
  }
  st->keypoint_rms_m = n_err > 0 ? std::sqrt(sum_sq / static_cast<double>(n_err)) : 0.0;
  st->character_travel_m =
      std::hypot(pelvis_last.x() - pelvis_first.x(), pelvis_last.y() - pelvis_first.y());
  return sole_actual;
}

/// The slide of sole column `col` over contact `i` into `step`: how far the character's sole
/// point moves horizontally from where it stood at the contact's first solved frame, and how
/// far off the floor it is.
void measure_slide(const Interval& i, int col, const std::vector<Eigen::Matrix3Xd>& sole_actual,
                   const Eigen::MatrixXd& qpos, StanceStep* step) {
  bool started = false;
  Vector3d start = Vector3d::Zero();  // where the point stood at its first solved frame
  for (int f = i.first; f <= i.second; ++f) {
    if (!qpos.row(f).allFinite()) continue;
    const Vector3d x = sole_actual[at(f)].col(col);
    if (!started) start = x;
    started = true;
    const double slide = std::hypot(x.x() - start.x(), x.y() - start.y());
    if (slide > step->slide_m) {
      step->slide_m = slide;
      step->slide_frame = f;
    }
    step->height_error_m = std::max(step->height_error_m, std::abs(x.z()));
  }
}

/// The contacts of the foot on side s into `result`, and its stances (its contacts that
/// overlap or touch) with the slide of the character's sole points over their contacts.
void add_contacts_and_steps(const FootTrack& foot, int s,
                            const std::vector<Eigen::Matrix3Xd>& sole_actual,
                            const Eigen::MatrixXd& qpos, RetargetResult* result) {
  std::vector<std::pair<Interval, int>> all;  // interval, sole point
  for (int p = 0; p < kSoles; ++p) {
    for (const Interval& i : foot.contacts[at(p)]) {
      result->contacts.push_back({kSides[s][0], Sole::kNames[p], i.first, i.second});
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
    measure_slide(i, s * kSoles + p, sole_actual, qpos, &step);
  }
  result->steps.insert(result->steps.end(), steps.begin(), steps.end());
}

/// Why a step slid: the leg's joints held on a limit at its worst frame (the capture's pose is
/// beyond the character's range of motion there, so no IK solution keeps the sole still).
void explain_slides(const sim::Model& model, sim::Data* data, const Eigen::MatrixXd& qpos,
                    std::vector<StanceStep>* steps) {
  for (StanceStep& step : *steps) {
    if (step.slide_frame < 0) continue;
    for (int k = 0; k < model->nq; ++k) (*data)->qpos[k] = qpos(step.slide_frame, k);
    step.joints_at_limit = leg_joints_at_limit(*model, (*data)->qpos, step.side);
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
  const RetargetInput in = read_input(motion, map, resolved, spec, units, options.source);
  const int frames = in.frames;
  const double dt = in.dt;

  // Free targets on the character's proportions. The free roll of the feet is level: a
  // marker-based foot bone's roll about itself is poorly seen.
  const LegScale legs = measure_legs(in, options.contacts);
  const Placement placement = place_capture(in, legs, options.align_start);
  std::array<FootCalibration, 2> calibration;
  std::array<FootTrack, 2> feet;
  for (int s = 0; s < 2; ++s) {
    calibration[at(s)] = calibrate_foot(in, legs, s);
    feet[at(s)] = start_foot_track(in, calibration[at(s)], s);
  }
  const std::vector<Eigen::Matrix3Xd> kp_target = free_targets(in, placement, calibration, &feet);

  // The sole points' contacts on their free trajectories, and the pins.
  const int blend = std::max(1, static_cast<int>(std::lround(options.blend_s / dt)));
  for (FootTrack& foot : feet) plan_contacts(options.contacts, dt, blend, &foot);

  // The character with its IK sites (the retargeting markers), and the IK.
  RetargetResult result;
  result.spec = spec;
  result.spec.markers.clear();
  IkSites sites = add_ik_sites(in, feet, calibration, options.contact_weight, &result.spec);
  const models::Character character = models::generate_character(result.spec);
  const sim::Model model =
      sim::Model::from_string(models::to_mjcf(character), "retargeting character");
  const std::vector<int> site_of_label = label_sites(model, sites.labels);
  result.targets = initial_targets(kp_target, feet, sites, dt);
  RetargetStats& st = result.stats;
  const auto t_ik = std::chrono::steady_clock::now();
  sim::Data data(*model);
  const IkSolution ik = solve_ik(model, site_of_label, options, blend, &sites, &feet,
                                 &result.targets, &data, &st, progress);
  const Eigen::MatrixXd& qpos = ik.qpos;
  st.ik_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_ik).count();

  // Statistics from MuJoCo's kinematics of the output.
  st.frames = frames;
  st.scale = legs.scale;
  st.bvh_leg_m = legs.bvh_leg_m;
  st.character_leg_m = legs.character_leg_m;
  st.mean_ik_iterations = frames > st.unsolved_frames
                              ? static_cast<double>(ik.iterations) / (frames - st.unsolved_frames)
                              : 0.0;
  const std::vector<Eigen::Matrix3Xd> sole_actual =
      measure_output(model, &data, site_of_label, sites, qpos, result.targets.positions_m, &st);
  const Vector3d b0 = in.cap.position(*placement.pelvis, 0),
                 b1 = in.cap.position(*placement.pelvis, frames - 1);
  st.bvh_travel_m = std::hypot(b1.x() - b0.x(), b1.y() - b0.y());
  for (int s = 0; s < 2; ++s) add_contacts_and_steps(feet[at(s)], s, sole_actual, qpos, &result);
  explain_slides(model, &data, qpos, &result.steps);
  std::sort(result.steps.begin(), result.steps.end(),
            [](const StanceStep& a, const StanceStep& b) { return a.first_frame < b.first_frame; });
  for (const StanceStep& step : result.steps)
    st.max_slide_m = std::max(st.max_slide_m, step.slide_m);

  // Outputs.
  result.motion.columns = qpos_names(*model);
  result.motion.qpos = qpos;
  for (int f = 0; f < frames; ++f) result.motion.times_s.push_back(f * dt);
  result.motion.comments = {
      " biodyn retarget of " + options.source + " (joint map " + map.name + ")",
      " character: " + std::string(models::to_string(spec.sex)) + ", " +
          std::to_string(spec.height_m) + " m, " + std::to_string(spec.mass_kg) + " kg, " +
          models::to_string(spec.detail) + " detail",
      " scale (leg length ratio): " + std::to_string(legs.scale)};
  set_motion_body(&result.motion, spec);
  result.bvh = character_bvh(character, *model, qpos, dt, options.output_units);
  st.total_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return result;
}

BvhMotion motion_bvh(const Motion& motion, const std::string& source) {
  const Motion solved = longest_solved_span(motion);
  if (solved.frame_count() < 2) {
    throw InvalidArgument(source + ": fewer than 2 solved frames in a row (" +
                          std::to_string(solved.frame_count()) + "): nothing to retarget");
  }
  const std::optional<models::CharacterSpec> body = motion_body(solved, source);
  if (!body) {
    throw InvalidArgument(source +
                          ": a qpos CSV needs its body in the header to be retargeted (# body: "
                          "..., as mocap ik and retarget write)");
  }
  const models::Character from = models::generate_character(*body);
  const sim::Model model = sim::Model::from_string(models::to_mjcf(from), "source body");
  check_motion_matches(solved, *model, source);
  return character_bvh(from, *model, solved.qpos, solved.times_s[1] - solved.times_s[0]);
}

std::optional<JointMap> first_fitting_builtin_map(const BvhMotion& motion,
                                                  const std::string& bvh_source,
                                                  std::string* tried) {
  for (const std::string& name : builtin_joint_map_names()) {
    JointMap map = builtin_joint_map(name);
    try {
      resolve_joint_map(map, motion, bvh_source);
      return map;
    } catch (const sim::InvalidArgument& e) {
      if (tried) *tried += std::string("\n  ") + e.what();
    }
  }
  return std::nullopt;
}

Motion retarget_bvh_file(const std::string& path, const models::CharacterSpec& character) {
  const BvhMotion bvh = read_bvh(path);
  std::string tried;
  if (const auto map = first_fitting_builtin_map(bvh, path, &tried)) {
    RetargetOptions options;
    options.source = path;
    return retarget_bvh(bvh, *map, character, options).motion;
  }
  throw sim::InvalidArgument(path +
                             ": no built-in joint map fits this BVH (retarget it with "
                             "biodyn mocap retarget --map, then use its motion.csv):" +
                             tried);
}

}  // namespace biodyn::mocap_io
