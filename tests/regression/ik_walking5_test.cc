// Regression (issue 24): marker IK of OpenSim's walking5.c3d scaled and placed from the capture
// itself, checked against what the capture says independently of the fit: the pelvis heading
// against the anterior superior iliac spines' axis, and the model's hip centres against the
// capture software's hip joint centres (LHJC, RHJC). On 777bb0d the heading was off by -17 deg
// (the right pelvis markers started on the left and the placement moved every marker, the joint
// centres too, so nothing anchored the pelvis) and the hip centres by ~5 cm.

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "biodyn/mocap_io/c3d.h"
#include "biodyn/mocap_io/inverse_dynamics.h"
#include "biodyn/mocap_io/marker_ik.h"
#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/mocap_io/scaling.h"
#include "biodyn/models/marker_set.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/units.h"
#include "test_support.h"

using namespace biodyn;

namespace {

const std::string kWalking5 =
    biodyn::testing::source_dir() + "/../shared/data/mocap/c3d/opensim_walking5.c3d";

// The bounds.
constexpr double kHeadingBound_deg = 2.0;
constexpr double kHipCentreBound_m = 0.01;
constexpr double kFrameRmsBound_m = 0.02;
constexpr double kFrameMaxBound_m = 0.04;

/// Heading (deg, about z from +x) of a horizontal direction.
double heading_deg(const Eigen::Vector3d& v) { return kDegPerRad * std::atan2(v.y(), v.x()); }

double wrapped_deg(double a) { return std::remainder(a, 360.0); }

struct Walking5Ik {
  mocap_io::MarkerData markers;
  models::CharacterSpec spec;
  sim::Model model;
  mocap_io::MarkerIkResult ik;
};

/// The CLI's pipeline without a separate static trial: scale and place from the trial itself.
Walking5Ik solve_walking5(mocap_io::MarkerData markers) {
  const models::MarkerSet set = models::builtin_marker_set("opensim_walking5");
  const mocap_io::ScaleResult scaled =
      mocap_io::scale_from_static(models::CharacterSpec{}, false, set, markers);
  sim::Model model = sim::Model::from_string(
      models::to_mjcf(models::generate_character(scaled.spec)), "walking5 subject");
  std::vector<double> weights;
  for (const std::string& l : markers.labels) weights.push_back(set.weight(l));
  mocap_io::MarkerIkResult ik = mocap_io::solve_marker_ik(*model, markers, weights);
  return Walking5Ik{std::move(markers), scaled.spec, std::move(model), std::move(ik)};
}

const Walking5Ik& walking5_ik() {
  static const Walking5Ik run = solve_walking5(mocap_io::read_c3d(kWalking5).markers);
  return run;
}

/// Pelvis heading minus the ASIS axis's forward (deg) over the solved frames: mean and worst.
struct HeadingError {
  double mean_deg = 0.0, worst_deg = 0.0;
  int frames = 0;
};

HeadingError pelvis_heading_error(const Walking5Ik& run) {
  const mjModel& m = *run.model;
  const models::Rig rig(m);
  sim::Data d(m);
  const int lasi = run.markers.find("LASI"), rasi = run.markers.find("RASI");
  HeadingError out;
  for (int f = 0; f < run.markers.frame_count(); ++f) {
    if (!run.ik.frames[static_cast<size_t>(f)].solved) continue;
    if (!run.markers.visible(f, lasi) || !run.markers.visible(f, rasi)) continue;
    for (int k = 0; k < m.nq; ++k) d->qpos[k] = run.ik.qpos(f, k);
    mj_kinematics(&m, d.get());
    // Forward is the left-pointing ASIS axis turned by -90 deg; the pelvis's forward is its x.
    const Eigen::Vector3d left = run.markers.position(f, lasi) - run.markers.position(f, rasi);
    const Eigen::Vector3d x_pelvis(d->xmat[9 * rig.pelvis()], d->xmat[9 * rig.pelvis() + 3],
                                   d->xmat[9 * rig.pelvis() + 6]);
    const double diff = wrapped_deg(heading_deg(x_pelvis) - (heading_deg(left) - 90.0));
    out.mean_deg += diff;
    out.worst_deg = std::max(out.worst_deg, std::abs(diff));
    ++out.frames;
  }
  out.mean_deg /= std::max(out.frames, 1);
  return out;
}

}  // namespace

TEST_CASE("walking5 IK: pelvis heading follows the ASIS axis, hip centres the capture's HJC",
          "[mocap][ik][slow]") {
  const Walking5Ik& run = walking5_ik();
  const mjModel& m = *run.model;
  const models::Rig rig(m);
  sim::Data d(m);
  const int lhjc = run.markers.find("LHJC"), rhjc = run.markers.find("RHJC");
  const int thigh_l = rig.body("thigh_l"), thigh_r = rig.body("thigh_r");
  double hip_sq[2] = {0, 0}, hip_max[2] = {0, 0};
  int hip_frames = 0;
  for (int f = 0; f < run.markers.frame_count(); ++f) {
    if (!run.ik.frames[static_cast<size_t>(f)].solved) continue;
    for (int k = 0; k < m.nq; ++k) d->qpos[k] = run.ik.qpos(f, k);
    mj_kinematics(&m, d.get());
    if (run.markers.visible(f, lhjc) && run.markers.visible(f, rhjc)) {
      const int body[2] = {thigh_l, thigh_r}, col[2] = {lhjc, rhjc};
      for (int s = 0; s < 2; ++s) {
        const double e =
            (Eigen::Vector3d(d->xpos + 3 * body[s]) - run.markers.position(f, col[s])).norm();
        hip_sq[s] += e * e;
        hip_max[s] = std::max(hip_max[s], e);
      }
      ++hip_frames;
    }
  }
  const HeadingError heading = pelvis_heading_error(run);
  REQUIRE(heading.frames > 400);
  REQUIRE(hip_frames > 400);
  INFO("pelvis heading - ASIS axis: mean " << heading.mean_deg << " deg, worst frame "
                                           << heading.worst_deg << " deg over " << heading.frames
                                           << " frames");
  INFO("hip centre - HJC: RMS left " << 1000 * std::sqrt(hip_sq[0] / hip_frames) << " mm, right "
                                     << 1000 * std::sqrt(hip_sq[1] / hip_frames)
                                     << " mm; worst frame " << 1000 * hip_max[0] << " / "
                                     << 1000 * hip_max[1] << " mm");
  CHECK(std::abs(heading.mean_deg) < kHeadingBound_deg);
  CHECK(std::sqrt(hip_sq[0] / hip_frames) < kHipCentreBound_m);
  CHECK(std::sqrt(hip_sq[1] / hip_frames) < kHipCentreBound_m);
}

TEST_CASE("walking5 IK: every solved frame fits within 2 cm RMS and 4 cm max",
          "[mocap][ik][slow]") {
  const Walking5Ik& run = walking5_ik();
  int solved = 0;
  double worst_rms = 0.0, worst_max = 0.0;
  for (const mocap_io::MarkerIkFrame& fr : run.ik.frames) {
    if (!fr.solved) continue;
    ++solved;
    worst_rms = std::max(worst_rms, fr.rms_error_m);
    worst_max = std::max(worst_max, fr.max_error_m);
  }
  INFO(solved << " frames solved; worst frame RMS " << 1000 * worst_rms << " mm, largest marker "
              << "error " << 1000 * worst_max << " mm");
  // Frames 415-980 show the pelvis and enough markers (566 on 777bb0d).
  CHECK(solved >= 560);
  CHECK(worst_rms < kFrameRmsBound_m);
  CHECK(worst_max < kFrameMaxBound_m);
  // The estimated stature: walking5's subject, from its leg and trunk measurements.
  CHECK(run.spec.height_m > 1.6);
  CHECK(run.spec.height_m < 2.0);
}

TEST_CASE("walking5 IK: the heading holds for the same walk in any direction of the lab",
          "[mocap][ik][slow]") {
  // Held out: the capture turned about the vertical by seeded random angles (and moved), as
  // if the lab's x axis pointed elsewhere; the fit must not prefer any lab direction.
  std::mt19937 rng(24);
  std::uniform_real_distribution<double> angle(-biodyn::kPi, biodyn::kPi), shift(-3.0, 3.0);
  for (int trial = 0; trial < 2; ++trial) {
    mocap_io::MarkerData markers = mocap_io::read_c3d(kWalking5).markers;
    const double a = angle(rng);
    const Eigen::Matrix3d r = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector3d t(shift(rng), shift(rng), 0.0);
    for (int f = 0; f < markers.frame_count(); ++f) {
      for (int i = 0; i < markers.marker_count(); ++i) {
        if (!markers.visible(f, i)) continue;
        markers.positions_m.row(f).segment<3>(3 * i) = (r * markers.position(f, i) + t).transpose();
      }
    }
    const HeadingError heading = pelvis_heading_error(solve_walking5(std::move(markers)));
    INFO("lab turned by " << kDegPerRad * a << " deg: pelvis heading - ASIS axis mean "
                          << heading.mean_deg << " deg, worst " << heading.worst_deg);
    REQUIRE(heading.frames > 400);
    CHECK(std::abs(heading.mean_deg) < kHeadingBound_deg);
  }
}

namespace {

/// The IK's longest run of solved frames as a motion (what `mocap id` runs on).
mocap_io::Motion solved_motion(const Walking5Ik& run) {
  int best_start = 0, best_len = 0, start = 0;
  const int frames = run.markers.frame_count();
  for (int f = 0; f <= frames; ++f) {
    if (f < frames && run.ik.frames[static_cast<size_t>(f)].solved) continue;
    if (f - start > best_len) {
      best_len = f - start;
      best_start = start;
    }
    start = f + 1;
  }
  mocap_io::Motion motion;
  motion.columns = mocap_io::qpos_names(*run.model);
  motion.qpos = run.ik.qpos.middleRows(best_start, best_len);
  for (int f = best_start; f < best_start + best_len; ++f) {
    motion.times_s.push_back(run.markers.time_s(f));
  }
  return motion;
}

/// The centre of pressure of `plate` at time `t_s` (nearest sample).
Eigen::Vector3d plate_cop(const mocap_io::ForcePlate& plate, double rate_hz, double t_s) {
  const int sample =
      std::clamp(static_cast<int>(std::lround(t_s * rate_hz)), 0, plate.sample_count() - 1);
  return plate.cop_m.row(sample).transpose();
}

/// Whether `body`'s origin in `d` is over `plate` (inside its corners' bounding box).
bool over_plate(const mjData& d, int body, const mocap_io::ForcePlate& plate) {
  const auto& c = plate.corners_m;
  const double x = d.xpos[3 * body], y = d.xpos[3 * body + 1];
  return x >= c.row(0).minCoeff() && x <= c.row(0).maxCoeff() && y >= c.row(1).minCoeff() &&
         y <= c.row(1).maxCoeff();
}

/// The plates' loads assigned by inverse_dynamics on the walking5 IK, against what a plate's
/// visit says independently: the foot that struck it (the foot nearest its centre of pressure
/// when the load starts, the other being a step away) carries it for the whole visit.
struct PlateCheck {
  int visits = 0, loaded_frames = 0, on_striking_foot = 0, on_other_foot = 0;
  int crossing_frames = 0;              ///< the other foot over the loaded plate
  double worst_crossing_knee_Nm = 0.0;  ///< the other leg's knee then
  double worst_crossing_time_s = 0.0;
  double worst_other_knee_change_Nm = 0.0;  ///< the other knee, plates vs no ground force
};

PlateCheck check_plates(const mjModel& m, const mocap_io::Motion& motion,
                        const mocap_io::C3dFile& c3d) {
  mocap_io::InverseDynamicsOptions options;
  options.ground = mocap_io::GroundForces::kForcePlates;
  const mocap_io::InverseDynamicsResult id =
      mocap_io::inverse_dynamics(m, motion, options, c3d.force_plates, c3d.analog.rate_hz);
  options.ground = mocap_io::GroundForces::kNone;
  const mocap_io::InverseDynamicsResult free = mocap_io::inverse_dynamics(m, motion, options);
  const models::Rig rig(m);
  sim::Data d(m);
  Eigen::Index knee[2];
  for (int s = 0; s < 2; ++s) {
    const char* name = s == models::kLeft ? "knee_flexion_l" : "knee_flexion_r";
    knee[s] = std::find(id.dof_names.begin(), id.dof_names.end(), name) - id.dof_names.begin();
  }
  PlateCheck out;
  for (Eigen::Index p = 0; p < id.plate_foot.cols(); ++p) {
    const mocap_io::ForcePlate& plate = c3d.force_plates[static_cast<size_t>(p)];
    int striking = -1;
    for (Eigen::Index i = 0; i < id.plate_foot.rows(); ++i) {
      if (id.plate_foot(i, p) == mocap_io::kPlateUnloaded) {
        striking = -1;
        continue;
      }
      const int f = static_cast<int>(i) + options.trim_frames;
      for (int k = 0; k < m.nq; ++k) d->qpos[k] = motion.qpos(f, k);
      mj_kinematics(&m, d.get());
      if (striking < 0) {  // a new visit
        ++out.visits;
        const Eigen::Vector3d cop = plate_cop(plate, c3d.analog.rate_hz, id.times_s[size_t(i)]);
        double best = 1e9;
        for (int s = 0; s < 2; ++s) {
          const int foot = rig.leg(s).foot;
          const double dist = (Eigen::Vector3d(d->xpos + 3 * foot) - cop).head<2>().norm();
          if (dist < best) best = dist, striking = s;
        }
      }
      const int other = 1 - striking;
      ++out.loaded_frames;
      out.on_striking_foot += id.plate_foot(i, p) == striking;
      out.on_other_foot += id.plate_foot(i, p) == other;
      bool other_loaded = false;  // the other foot on the other plate (double support)
      for (Eigen::Index q = 0; q < id.plate_foot.cols(); ++q) {
        other_loaded = other_loaded || id.plate_foot(i, q) == other;
      }
      if (other_loaded) continue;
      const double knee_other = id.generalized_force(i, knee[other]);
      out.worst_other_knee_change_Nm =
          std::max(out.worst_other_knee_change_Nm,
                   std::abs(knee_other - free.generalized_force(i, knee[other])));
      if (over_plate(*d, rig.leg(other).foot, plate)) {
        ++out.crossing_frames;
        if (std::abs(knee_other) > out.worst_crossing_knee_Nm) {
          out.worst_crossing_knee_Nm = std::abs(knee_other);
          out.worst_crossing_time_s = id.times_s[static_cast<size_t>(i)];
        }
      }
    }
  }
  return out;
}

}  // namespace

TEST_CASE("walking5 ID with the force plates: a swing foot crossing a loaded plate takes no load",
          "[mocap][id][slow]") {
  // On 777bb0d a plate's load went to the foot whose ankle was horizontally nearest the centre
  // of pressure: a swing foot passing over the stance foot's plate took its load and the swing
  // knee showed 65-77 N m.
  const Walking5Ik& run = walking5_ik();
  const PlateCheck c = check_plates(*run.model, solved_motion(run), mocap_io::read_c3d(kWalking5));
  INFO(c.visits << " plate visits, " << c.loaded_frames << " loaded frames: " << c.on_striking_foot
                << " on the foot that struck the plate, " << c.on_other_foot
                << " on the other foot; " << c.crossing_frames
                << " frames with the other foot over the loaded plate, its knee moment up to "
                << c.worst_crossing_knee_Nm << " N m (t = " << c.worst_crossing_time_s
                << " s); the other knee differs from ID without "
                << "ground forces by up to " << c.worst_other_knee_change_Nm << " N m");
  REQUIRE(c.visits >= 2);
  REQUIRE(c.crossing_frames > 20);  // the case the defect is about happens in this capture
  CHECK(c.on_other_foot == 0);
  CHECK(c.on_striking_foot >= 0.97 * c.loaded_frames);
  // No plate force reaches the swinging leg: its knee needs what it needs with no ground at
  // all. (The issue asks < 20 N m for that knee; it peaks at 21.8 N m at t = 2.29 s, terminal
  // swing of the right leg over the left foot's plate, the same value with no ground force: the
  // leg's own deceleration on the default 80 kg body, not a plate load. Reported, not bounded.)
  CHECK(c.worst_other_knee_change_Nm < 1e-6);
}

TEST_CASE("walking5 ID with the force plates: the same assignment in any direction of the lab",
          "[mocap][id][slow]") {
  // Held out: markers and plates turned about the vertical and moved by a seeded random
  // transform; the assignment must hold without knowing which way the walkway runs.
  std::mt19937 rng(2424);
  std::uniform_real_distribution<double> angle(-biodyn::kPi, biodyn::kPi), shift(-3.0, 3.0);
  mocap_io::C3dFile c3d = mocap_io::read_c3d(kWalking5);
  const Eigen::Matrix3d r =
      Eigen::AngleAxisd(angle(rng), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d t(shift(rng), shift(rng), 0.0);
  mocap_io::MarkerData& markers = c3d.markers;
  for (int f = 0; f < markers.frame_count(); ++f) {
    for (int i = 0; i < markers.marker_count(); ++i) {
      if (!markers.visible(f, i)) continue;
      markers.positions_m.row(f).segment<3>(3 * i) = (r * markers.position(f, i) + t).transpose();
    }
  }
  for (mocap_io::ForcePlate& p : c3d.force_plates) {
    p.corners_m = (r * p.corners_m).colwise() + t;
    p.force_N = p.force_N * r.transpose();
    p.free_moment_Nm = p.free_moment_Nm * r.transpose();
    p.moment_origin_Nm = p.moment_origin_Nm * r.transpose();
    p.cop_m = (p.cop_m * r.transpose()).rowwise() + t.transpose();
  }
  const Walking5Ik run = solve_walking5(c3d.markers);
  const PlateCheck c = check_plates(*run.model, solved_motion(run), c3d);
  INFO(c.visits << " visits, " << c.loaded_frames << " loaded frames: " << c.on_striking_foot
                << " on the striking foot, " << c.on_other_foot << " on the other");
  REQUIRE(c.visits >= 2);
  CHECK(c.on_other_foot == 0);
  CHECK(c.on_striking_foot >= 0.97 * c.loaded_frames);
  CHECK(c.worst_other_knee_change_Nm < 1e-6);
}
