// A simulated walk recorded as a motion (motion_recorder.h), and that motion's ground forces
// estimated from its kinematics alone (mocap_io/ground_force_estimate.h) against the ones the
// simulation applied: a held-out check of the estimate on a body and gait it was not tuned on.
#include <array>
#include <catch2/catch.hpp>
#include <cmath>

#include "biodyn/mocap_io/inverse_dynamics.h"
#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/motion_recorder.h"
#include "biodyn/scenarios/walk.h"
#include "biodyn/sim/model.h"
#include "test_support.h"

using namespace biodyn;

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "A recorded walk's ground forces, estimated from its kinematics, match the "
                 "simulation's",
                 "[scenarios][grf]") {
  constexpr double kDuration_s = 8.0, kRecord_hz = 100.0, kSkip_s = 2.0;
  models::CharacterSpec spec;  // a body the estimate was not tuned on (walking5 was)
  spec.height_m = 1.62;
  spec.mass_kg = 58;
  spec.sex = models::Sex::kFemale;
  sim::Simulation sim(
      sim::Model::from_string(models::to_mjcf(models::generate_character(spec)), "walker"));
  scenarios::WalkRunParams p;
  p.duration_s = kDuration_s;
  p.config.character = spec;
  p.config.speed_m_s = 1.1;
  const double dt = sim.model().opt.timestep;
  scenarios::MotionRecorder recorder(sim.model(),
                                     static_cast<int>(std::lround(1 / (kRecord_hz * dt))),
                                     std::lround(kDuration_s / dt) + 1);
  p.observers.push_back(&recorder);
  const scenarios::WalkRunResult r = scenarios::run_walk(&sim, p);
  REQUIRE_FALSE(r.fallen);
  const scenarios::RecordedMotion rec = recorder.motion();
  REQUIRE(rec.frame_count() == static_cast<int>(std::lround(kDuration_s * kRecord_hz)));

  mocap_io::Motion motion;
  motion.columns = mocap_io::qpos_names(sim.model());
  motion.times_s = rec.times_s;
  motion.qpos = rec.qpos;
  mocap_io::InverseDynamicsOptions options;
  options.ground = mocap_io::GroundForces::kEstimated;
  const mocap_io::InverseDynamicsResult id =
      mocap_io::inverse_dynamics(sim.model(), motion, options);
  double mass = 0;
  for (int b = 1; b < sim.model().nbody; ++b) mass += sim.model().body_mass[b];
  const double bw = mass * 9.81;
  // The simulation's forces seen through the kinematics' filter (6 Hz, zero lag): the estimate
  // cannot see a strike's impact above it. Frame i of the result is frame i + trim of the
  // recording.
  std::array<Eigen::MatrixXd, 2> simulated = rec.ground_force_N;
  for (Eigen::MatrixXd& f : simulated) mocap_io::low_pass(&f, kRecord_hz, options.filter);
  const int trim = options.trim_frames, skip = static_cast<int>(kSkip_s * kRecord_hz);
  const int n = static_cast<int>(id.ground_force_N.rows()) - skip;
  Eigen::VectorXd total = Eigen::VectorXd::Zero(n);
  double worst_share = 0;  // each foot's mean vertical force over the walk, estimate - simulated
  for (int side = 0; side < 2; ++side) {
    const Eigen::VectorXd err =
        id.ground_estimate.force_N[static_cast<size_t>(side)].col(2).tail(n) -
        simulated[static_cast<size_t>(side)].col(2).segment(skip + trim, n);
    worst_share = std::max(worst_share, std::abs(err.mean()) / bw);
    total += err;
  }
  const double total_rms = std::sqrt(total.squaredNorm() / n) / bw;
  INFO("after " << kSkip_s << " s, against the simulation's forces low-passed like the "
                << "kinematics: total vertical RMS " << 100 * total_rms << "% BW; each foot's "
                << "mean off by up to " << 100 * worst_share << "% BW");
  // The walker's double support lasts 1-3 frames with 2 BW impacts (it is no human gait): the
  // split per frame is not checked here (walking5's plates check it), the total and each foot's
  // share of the load over the walk are.
  CHECK(total_rms < 0.08);
  CHECK(worst_share < 0.03);
  CHECK(id.ground_force_N.col(2).maxCoeff() < 3.0 * bw);
}
