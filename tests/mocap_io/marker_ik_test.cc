// Marker IK on synthetic captures: markers from known poses of the generated character (plus
// seeded noise) must give back the poses, and the marker error must be the noise.
#include "biodyn/mocap_io/marker_ik.h"

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "biodyn/models/marker_set.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;

namespace {

constexpr double kNoise_m = 0.002;        // the 2 mm, per coordinate
constexpr double kRate_hz = 100.0;        // synthetic capture rate
constexpr int kIkFrames = 300;            // 3 s
constexpr double kMaxJointRms_deg = 2.0;  // the joint-angle bound

/// Cluster geometry: a rigid plate of 3 markers on every segment (as real clusters and wands
/// are), its centre kClusterStandoff_m off the segment's CoM, markers kClusterSize_m apart.
constexpr double kClusterStandoff_m = 0.08;
constexpr double kClusterSize_m = 0.08;  // m; rigid plates are 8-12 cm across

/// Three markers on a plate per segment of the full character.
std::vector<models::MarkerPlacement> cluster_markers() {
  const models::Character plain = models::generate_character(models::CharacterSpec{});
  std::vector<models::MarkerPlacement> out;
  for (const models::Segment& seg : plain.segments) {
    const bool left = seg.name.size() > 2 && seg.name.substr(seg.name.size() - 2) == "_l";
    const bool right = seg.name.size() > 2 && seg.name.substr(seg.name.size() - 2) == "_r";
    // Stand-off direction: lateral for limbs, forward for the trunk, neck and head.
    const Eigen::Vector3d out_dir(left || right ? 0.0 : 1.0, left ? 1.0 : (right ? -1.0 : 0.0),
                                  0.0);
    const Eigen::Vector3d across = out_dir.cross(Eigen::Vector3d::UnitZ()).normalized();
    const Eigen::Vector3d centre = seg.com_B + kClusterStandoff_m * out_dir;
    const Eigen::Vector3d corners[] = {
        centre + kClusterSize_m * Eigen::Vector3d::UnitZ(),
        centre - 0.5 * kClusterSize_m * Eigen::Vector3d::UnitZ() + 0.8 * kClusterSize_m * across,
        centre - 0.5 * kClusterSize_m * Eigen::Vector3d::UnitZ() - 0.8 * kClusterSize_m * across};
    for (int k = 0; k < 3; ++k) {
      models::MarkerPlacement p;
      p.name = seg.name + "_C" + std::to_string(k + 1);
      p.part = seg.name;
      p.position_B = corners[k];
      out.push_back(p);
    }
  }
  return out;
}

/// The full character carrying the given built-in marker set, or "clusters" (cluster_markers).
sim::Model character_with(const std::string& marker_set) {
  models::CharacterSpec spec;
  spec.markers =
      marker_set == "clusters" ? cluster_markers() : models::builtin_marker_set(marker_set).markers;
  return testing::generated_character(spec);
}

/// A smooth random motion within the joint ranges: each hinge oscillates about a random centre
/// inside its range, each ball joint's rotation vector oscillates per axis, the root walks
/// forward while turning and swaying. Seeded.
Eigen::MatrixXd random_motion(const mjModel& m, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Eigen::MatrixXd q(kIkFrames, m.nq);
  struct Wave {
    double centre, amp, freq, phase;
  };
  std::vector<std::vector<Wave>> waves(static_cast<size_t>(m.njnt));
  for (int j = 0; j < m.njnt; ++j) {
    const int n = m.jnt_type[j] == mjJNT_BALL ? 3 : (m.jnt_type[j] == mjJNT_FREE ? 0 : 1);
    for (int k = 0; k < n; ++k) {
      Wave w{};
      if (m.jnt_type[j] == mjJNT_HINGE) {
        const double lo = m.jnt_range[2 * j], hi = m.jnt_range[2 * j + 1];
        const double span = hi - lo;
        w.centre = lo + span * (0.3 + 0.4 * u(rng));
        w.amp = std::min(w.centre - lo, hi - w.centre) * 0.8 * u(rng);
      } else {  // ball: rotation vector components up to 0.35 rad (inside every cone limit)
        w.centre = 0.2 * (u(rng) - 0.5);
        w.amp = 0.25 * u(rng);
      }
      w.freq = 0.3 + 1.2 * u(rng);
      w.phase = 2 * kPi * u(rng);
      waves[static_cast<size_t>(j)].push_back(w);
    }
  }
  for (int f = 0; f < kIkFrames; ++f) {
    const double t = f / kRate_hz;
    for (int j = 0; j < m.njnt; ++j) {
      const int a = m.jnt_qposadr[j];
      const auto& w = waves[static_cast<size_t>(j)];
      auto val = [&](size_t k) {
        return w[k].centre + w[k].amp * std::sin(2 * kPi * w[k].freq * t + w[k].phase);
      };
      switch (m.jnt_type[j]) {
        case mjJNT_FREE: {
          q(f, a) = 1.0 * t;
          q(f, a + 1) = 0.05 * std::sin(2 * kPi * 0.9 * t);
          q(f, a + 2) = 0.95 + 0.03 * std::sin(2 * kPi * 1.8 * t);
          const Eigen::Quaterniond r(
              Eigen::AngleAxisd(0.4 * t, Eigen::Vector3d::UnitZ()) *
              Eigen::AngleAxisd(0.1 * std::sin(3 * t), Eigen::Vector3d::UnitX()));
          q(f, a + 3) = r.w();
          q(f, a + 4) = r.x();
          q(f, a + 5) = r.y();
          q(f, a + 6) = r.z();
          break;
        }
        case mjJNT_BALL: {
          const Eigen::Vector3d rv(val(0), val(1), val(2));
          const Eigen::Quaterniond r(Eigen::AngleAxisd(rv.norm(), rv.normalized()));
          q(f, a) = r.w();
          q(f, a + 1) = r.x();
          q(f, a + 2) = r.y();
          q(f, a + 3) = r.z();
          break;
        }
        default:
          q(f, a) = val(0);
      }
    }
  }
  return q;
}

/// Marker positions of every site "marker_*" of `m` along motion `q`, plus noise.
mocap_io::MarkerData synthetic_capture(const mjModel& m, const Eigen::MatrixXd& q, double noise_m,
                                       unsigned seed) {
  mocap_io::MarkerData data;
  data.rate_hz = kRate_hz;
  std::vector<int> sites;
  for (int s = 0; s < m.nsite; ++s) {
    const std::string name = mj_id2name(&m, mjOBJ_SITE, s);
    if (name.rfind("marker_", 0) == 0) {
      data.labels.push_back(name.substr(7));
      sites.push_back(s);
    }
  }
  sim::Data d(m);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_m);
  data.positions_m.resize(q.rows(), 3 * static_cast<Eigen::Index>(sites.size()));
  for (Eigen::Index f = 0; f < q.rows(); ++f) {
    for (int k = 0; k < m.nq; ++k) d->qpos[k] = q(f, k);
    mj_kinematics(&m, d.get());
    for (size_t i = 0; i < sites.size(); ++i) {
      for (int k = 0; k < 3; ++k) {
        data.positions_m(f, static_cast<Eigen::Index>(3 * i + k)) =
            d->site_xpos[3 * sites[i] + k] + (noise_m > 0 ? noise(rng) : 0.0);
      }
    }
  }
  return data;
}

struct Recovery {
  double worst_joint_rms_deg = 0, worst_joint_max_deg = 0;
  std::string worst_joint;
  double marker_rms_m = 0;  // RMS over all frames and markers
  int solved = 0;
  double frames_per_second = 0;  // IK speed (the real solve, reported: not a timed assertion)
};

Recovery recover(const std::string& marker_set, double noise_m, unsigned seed) {
  const sim::Model model = character_with(marker_set);
  const mjModel& m = *model;
  const Eigen::MatrixXd truth = random_motion(m, seed);
  const mocap_io::MarkerData capture = synthetic_capture(m, truth, noise_m, seed + 1);
  const std::vector<double> weights(capture.labels.size(), 1.0);
  const mocap_io::MarkerIkResult ik = mocap_io::solve_marker_ik(m, capture, weights);
  Recovery r;
  r.frames_per_second = kIkFrames / ik.seconds;
  double sum_sq = 0;
  int n = 0;
  for (const mocap_io::MarkerIkFrame& f : ik.frames) {
    r.solved += f.solved ? 1 : 0;
    sum_sq += f.rms_error_m * f.rms_error_m * f.markers_used;
    n += f.markers_used;
  }
  r.marker_rms_m = std::sqrt(sum_sq / n);
  for (int j = 0; j < m.njnt; ++j) {
    double sq = 0, worst = 0;
    for (int f = 0; f < kIkFrames; ++f) {
      const double e = sim::joint_distance(m, j, truth.row(f), ik.qpos.row(f));
      sq += e * e;
      worst = std::max(worst, e);
    }
    const double rms_deg = std::sqrt(sq / kIkFrames) / kRadPerDeg;
    if (rms_deg > r.worst_joint_rms_deg) {
      r.worst_joint_rms_deg = rms_deg;
      r.worst_joint = mj_id2name(&m, mjOBJ_JOINT, j);
    }
    r.worst_joint_max_deg = std::max(r.worst_joint_max_deg, worst / kRadPerDeg);
  }
  return r;
}

}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Marker IK recovers known poses exactly from noise-free markers",
                 "[mocap_io][ik]") {
  const Recovery r = recover("full40", 0.0, 7);
  INFO("worst joint " << r.worst_joint << " rms " << r.worst_joint_rms_deg << " deg, max "
                      << r.worst_joint_max_deg << " deg; marker rms " << r.marker_rms_m);
  CHECK(r.solved == kIkFrames);
  CHECK(r.marker_rms_m < 1e-4);
  CHECK(r.worst_joint_max_deg < 0.5);
}

// With 2 mm noise a joint angle is only as good as the lever arm of the markers that see it:
// sigma_angle ~ noise / (distance from the axis * sqrt(markers)). Skin markers on a forearm
// (3-4 cm from its long axis) cannot resolve pronation to 2 degrees, which is why real marker
// sets use clusters and wands; this test uses a 3-marker cluster per segment. The skin-only
// sets are measured below and reported, not held to 2 degrees.
TEST_CASE_METHOD(
    biodyn::testing::SimulationTest,
    "Marker IK with 2 mm noise: joint angles within 2 degrees, marker error = the noise",
    "[mocap_io][ik]") {
  for (unsigned seed : {11u, 12u, 13u}) {
    const Recovery r = recover("clusters", kNoise_m, seed);
    // Expected residual of a least-squares fit: sigma * sqrt(3 - dof/markers) per marker.
    const double noise_rms_3d = kNoise_m * std::sqrt(3.0);
    INFO("seed " << seed << ": worst joint " << r.worst_joint << " rms " << r.worst_joint_rms_deg
                 << " deg (max " << r.worst_joint_max_deg << " deg); marker rms "
                 << r.marker_rms_m * 1000 << " mm vs noise " << noise_rms_3d * 1000 << " mm");
    CHECK(r.solved == kIkFrames);
    CHECK(r.worst_joint_rms_deg < kMaxJointRms_deg);
    CHECK(r.marker_rms_m < noise_rms_3d);
    CHECK(r.marker_rms_m > 0.6 * noise_rms_3d);
  }
}

TEST_CASE_METHOD(
    biodyn::testing::SimulationTest,
    "Marker IK with 2 mm noise on the skin-only sets: measured, markers fit to the noise",
    "[mocap_io][ik]") {
  for (const char* set : {"full40", "thesis26"}) {
    const Recovery r = recover(set, kNoise_m, 11);
    const double noise_rms_3d = kNoise_m * std::sqrt(3.0);
    WARN(set << ": worst joint " << r.worst_joint << " rms " << r.worst_joint_rms_deg
             << " deg (max " << r.worst_joint_max_deg << " deg); marker rms "
             << r.marker_rms_m * 1000 << " mm vs noise " << noise_rms_3d * 1000 << " mm; "
             << r.frames_per_second << " frames/s");
    CHECK(r.solved == kIkFrames);
    CHECK(r.marker_rms_m < noise_rms_3d);  // fits the markers no worse than the noise
  }
}

// Issue 24, defect 5: a TRC's "0 0 0" gaps once read as markers at the lab origin were
// "solved" at 0.5 m RMS with exit 0. Whatever puts markers in absurd places, a frame the body
// cannot fit is refused (unsolved, NaN pose), and the frames after it solve as before.
TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Marker IK refuses frames it cannot fit instead of reporting them solved",
                 "[mocap_io][ik]") {
  const sim::Model model = character_with("full40");
  const mjModel& m = *model;
  const Eigen::MatrixXd truth = random_motion(m, 24);
  mocap_io::MarkerData capture = synthetic_capture(m, truth, 0.0, 25);
  const std::vector<double> weights(capture.labels.size(), 1.0);
  // Frames 100-104: every marker at the origin; frame 200: one marker 1 m off.
  for (int f = 100; f < 105; ++f) capture.positions_m.row(f).setZero();
  capture.positions_m(200, 0) += 1.0;
  const mocap_io::MarkerIkResult ik = mocap_io::solve_marker_ik(m, capture, weights);
  for (int f : {100, 101, 102, 103, 104, 200}) {
    INFO("frame " << f << " RMS " << ik.frames[static_cast<size_t>(f)].rms_error_m);
    CHECK(ik.frames[static_cast<size_t>(f)].rejected);
    CHECK_FALSE(ik.frames[static_cast<size_t>(f)].solved);
    CHECK_FALSE(ik.qpos.row(f).allFinite());
  }
  CHECK(ik.rejected_count() == 6);
  CHECK(ik.solved_count() == kIkFrames - 6);
  // The frames after recover: the next one starts from the last accepted pose.
  for (int f : {105, 201}) CHECK(ik.frames[static_cast<size_t>(f)].rms_error_m < 1e-3);
  // A threshold must be positive.
  mocap_io::MarkerIkOptions bad;
  bad.max_frame_rms_m = 0.0;
  CHECK_THROWS_AS(mocap_io::solve_marker_ik(m, capture, weights, bad), sim::InvalidArgument);
}
