#pragma once
/// Records a simulated run as a motion: the pose (qpos) at a fixed rate, with each foot's ground
/// force (its weld plus the floor contacts of foot and toes, controllers/foot_contact.h). What
/// `biodyn walk --motion-out` writes; the motion can then be replayed, tracked or run through
/// inverse dynamics like a capture, with the simulation's own ground forces as the reference.

#include <Eigen/Core>
#include <array>
#include <vector>

#include "biodyn/scenarios/scenario.h"

namespace biodyn::scenarios {

struct RecordedMotion {
  std::vector<double> times_s;
  Eigen::MatrixXd qpos;  ///< frames x nq
  /// per side: frames x 3, world; each frame the mean over the steps since the last frame
  std::array<Eigen::MatrixXd, 2> ground_force_N;
  int frame_count() const { return static_cast<int>(times_s.size()); }
};

class MotionRecorder : public StepObserver {
 public:
  /// Records every `every_steps`-th step of a run of up to `max_steps` steps (storage is
  /// reserved up front: recording allocates nothing while the run steps).
  MotionRecorder(const mjModel& m, int every_steps, long max_steps);
  void on_step(const Scenario& scenario) override;
  /// The frames recorded so far (copies the reserved storage's used part).
  RecordedMotion motion() const;

 private:
  int nq_, every_;
  long steps_ = 0;
  int frames_ = 0;
  std::vector<double> times_;
  Eigen::MatrixXd qpos_;                  // nq x capacity (column per frame: contiguous writes)
  std::array<Eigen::MatrixXd, 2> force_;  // 3 x capacity
  std::array<Eigen::Vector3d, 2> sum_ = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  int summed_ = 0;
};

}  // namespace biodyn::scenarios
