// Records a simulated run as a motion (motion_recorder.h).
#include "biodyn/scenarios/motion_recorder.h"

#include <algorithm>

#include "biodyn/sim/errors.h"

namespace biodyn::scenarios {

MotionRecorder::MotionRecorder(const mjModel& m, int every_steps, long max_steps)
    : nq_(m.nq), every_(every_steps) {
  if (every_steps < 1) {
    throw sim::InvalidArgument("motion recording: every_steps must be >= 1, got " +
                               std::to_string(every_steps));
  }
  const long capacity = std::max(1L, max_steps / every_steps + 1);
  times_.resize(static_cast<size_t>(capacity));
  qpos_.resize(nq_, capacity);
  for (Eigen::MatrixXd& f : force_) f.resize(3, capacity);
}

void MotionRecorder::on_step(const Scenario& scenario) {
  const long step = steps_++;
  // Every step's ground force is summed: a frame holds the mean over the steps since the last
  // frame, so a strike's impact, a few steps long, is neither missed nor counted whole.
  const controllers::ControlPipeline* pipeline = scenario.pipeline();
  for (int side = 0; side < 2; ++side) {
    if (pipeline) sum_[static_cast<size_t>(side)] += pipeline->welds().wrench(side).ground_force_W;
  }
  ++summed_;
  if (step % every_ != 0 || frames_ >= static_cast<int>(times_.size())) return;
  const mjData& d = scenario.simulation().data();
  times_[static_cast<size_t>(frames_)] = d.time;
  for (int k = 0; k < nq_; ++k) qpos_(k, frames_) = d.qpos[k];
  for (int side = 0; side < 2; ++side) {
    force_[static_cast<size_t>(side)].col(frames_) = sum_[static_cast<size_t>(side)] / summed_;
    sum_[static_cast<size_t>(side)].setZero();
  }
  summed_ = 0;
  ++frames_;
}

RecordedMotion MotionRecorder::motion() const {
  RecordedMotion r;
  r.times_s.assign(times_.begin(), times_.begin() + frames_);
  r.qpos = qpos_.leftCols(frames_).transpose();
  for (int side = 0; side < 2; ++side) {
    r.ground_force_N[static_cast<size_t>(side)] =
        force_[static_cast<size_t>(side)].leftCols(frames_).transpose();
  }
  return r;
}

}  // namespace biodyn::scenarios
