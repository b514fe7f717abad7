// Ground forces from kinematics (ground_force_estimate.h): a body held still is carried by its
// feet with its weight and no residual; a lifted foot carries nothing; every foot's force is
// inside the friction pyramid; and the estimate replaces --grf contact inside inverse dynamics.
#include "biodyn/mocap_io/ground_force_estimate.h"

#include <Eigen/Geometry>
#include <cmath>

#include "biodyn/mocap_io/inverse_dynamics.h"
#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/model.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;

namespace {

constexpr int kHeldFrames = 60;
constexpr double kHeldRate_hz = 100.0;

/// A motion holding `q` still, its pelvis swaying sideways by `sway_m` (a slow sine): the body
/// needs m g up and a small sideways force.
mocap_io::Motion held_still(const mjModel& m, const Eigen::VectorXd& q, double sway_m) {
  mocap_io::Motion motion;
  motion.columns = mocap_io::qpos_names(m);
  motion.qpos = q.transpose().replicate(kHeldFrames, 1);
  for (int f = 0; f < kHeldFrames; ++f) {
    const double t = f / kHeldRate_hz;
    motion.times_s.push_back(t);
    motion.qpos(f, 1) += sway_m * std::sin(2.0 * M_PI * 0.5 * t);
  }
  return motion;
}

/// The standing pose with every sole corner at or above z = 0 and the lowest on it.
Eigen::VectorXd standing_on_floor(const mjModel& m) {
  Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(m.qpos0, m.nq);
  sim::Data d(m);
  for (int k = 0; k < m.nq; ++k) d->qpos[k] = q(k);
  mj_kinematics(&m, d.get());
  double low = 1e9;
  for (const mocap_io::SoleContactPoint& p : mocap_io::sole_contact_points(m)) {
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> r(d->xmat + 9 * p.body);
    low = std::min(low, d->xpos[3 * p.body + 2] + (r * p.pos_B).z());
  }
  q(2) -= low;
  return q;
}

double body_weight_N(const mjModel& m) {
  double mass = 0;
  for (int b = 1; b < m.nbody; ++b) mass += m.body_mass[b];
  return mass * 9.81;
}

}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Ground force estimate: a body standing still is carried by both feet",
                 "[mocap_io][grf]") {
  const sim::Model model = testing::generated_character();
  const mjModel& m = *model;
  mocap_io::InverseDynamicsOptions options;
  options.ground = mocap_io::GroundForces::kEstimated;
  const mocap_io::InverseDynamicsResult id =
      mocap_io::inverse_dynamics(m, held_still(m, standing_on_floor(m), 0.02), options);
  const double bw = body_weight_N(m);
  const mocap_io::GroundForceEstimate& e = id.ground_estimate;
  REQUIRE(e.points.size() == 16);  // 8 per foot: heel, midfoot, metatarsal, toe tip corners
  for (Eigen::Index f = 0; f < id.ground_force_N.rows(); ++f) {
    INFO("frame " << f << ": left " << e.force_N[0].row(f) << " N, right " << e.force_N[1].row(f)
                  << " N, body weight " << bw << " N");
    CHECK(id.ground_force_N(f, 2) == Approx(bw).epsilon(0.01));
    CHECK(id.residual_force_N.row(f).norm() < 0.01 * bw);
    for (int side = 0; side < 2; ++side) {
      const Eigen::Vector3d force = e.force_N[static_cast<size_t>(side)].row(f).transpose();
      CHECK(force.z() > 0.3 * bw);                              // both feet carry a share
      CHECK(force.head<2>().norm() <= 0.5 * force.z() + 1e-9);  // inside the pyramid (mu 0.5)
      // The centre of pressure lies under that foot (within its sole's length of the ankle).
      const int foot = models::Rig(m).leg(side).foot;
      sim::Data d(m);
      for (int k = 0; k < m.nq; ++k) d->qpos[k] = id.qpos(f, k);
      mj_kinematics(&m, d.get());
      const Eigen::Vector3d cop = e.cop_m[static_cast<size_t>(side)].row(f).transpose();
      CHECK((cop - Eigen::Vector3d(d->xpos + 3 * foot)).head<2>().norm() < 0.2);
    }
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Ground force estimate: a foot held 10 cm up carries nothing", "[mocap_io][grf]") {
  const sim::Model model = testing::generated_character();
  const mjModel& m = *model;
  const models::Rig rig(m);
  Eigen::VectorXd q = standing_on_floor(m);
  // Swing the right thigh 0.5 rad: that foot rises ~10 cm; the left stays on the floor.
  const models::JointGroup& hip = rig.groups()[static_cast<size_t>(rig.leg(models::kRight).hip)];
  const int hip_q = m.jnt_qposadr[m.dof_jntid[hip.dof_begin]];
  const Eigen::Quaterniond flex(Eigen::AngleAxisd(-0.5, Eigen::Vector3d::UnitY()));
  q.segment<4>(hip_q) << flex.w(), flex.x(), flex.y(), flex.z();
  sim::Data d(m);
  for (int k = 0; k < m.nq; ++k) d->qpos[k] = q(k);
  mj_kinematics(&m, d.get());
  double right_low = 1e9;
  for (const mocap_io::SoleContactPoint& p : mocap_io::sole_contact_points(m)) {
    if (p.side != models::kRight) continue;
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> r(d->xmat + 9 * p.body);
    right_low = std::min(right_low, d->xpos[3 * p.body + 2] + (r * p.pos_B).z());
  }
  REQUIRE(right_low > 0.08);
  mocap_io::InverseDynamicsOptions options;
  options.ground = mocap_io::GroundForces::kEstimated;
  const mocap_io::InverseDynamicsResult id =
      mocap_io::inverse_dynamics(m, held_still(m, q, 0.0), options);
  const double bw = body_weight_N(m);
  CHECK(id.ground_estimate.force_N[models::kRight].cwiseAbs().maxCoeff() == 0.0);
  CHECK(id.ground_estimate.force_N[models::kLeft].col(2).minCoeff() > 0.5 * bw);
}
