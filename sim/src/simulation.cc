#include "biodyn/sim/simulation.h"

#include <cmath>
#include <sstream>

#include "biodyn/sim/errors.h"

namespace biodyn::sim {

long WarningCounts::total() const {
  long sum = 0;
  for (long c : count) sum += c;
  return sum;
}

std::string WarningCounts::describe() const {
  std::ostringstream out;
  bool first = true;
  for (int i = 0; i < mjNWARNING; ++i) {
    if (count[i] == 0) continue;
    out << (first ? "" : ", ") << warning_name(i) << " x" << count[i];
    first = false;
  }
  return first ? "none" : out.str();
}

long WarningCounts::diverged() const {
  return count[mjWARN_BADQPOS] + count[mjWARN_BADQVEL] + count[mjWARN_BADQACC];
}

WarningCounts& WarningCounts::operator+=(const WarningCounts& other) {
  for (int i = 0; i < mjNWARNING; ++i) count[i] += other.count[i];
  return *this;
}

const char* warning_name(int warning) {
  switch (warning) {
    case mjWARN_INERTIA:
      return "singular inertia";
    case mjWARN_CONTACTFULL:
      return "contact list full";
    case mjWARN_CNSTRFULL:
      return "constraint list full";
    case mjWARN_VGEOMFULL:
      return "visual geom list full";
    case mjWARN_BADQPOS:
      return "bad qpos";
    case mjWARN_BADQVEL:
      return "bad qvel";
    case mjWARN_BADQACC:
      return "bad qacc";
    case mjWARN_BADCTRL:
      return "bad ctrl";
    default:
      return "unknown warning";
  }
}

Simulation::Simulation(Model model) : model_(std::move(model)), data_(*model_), scratch_(*model_) {
  reset();
}

void Simulation::reset(int key) {
  if (key >= 0) {
    if (key >= model_->nkey) {
      throw InvalidArgument("reset: keyframe " + std::to_string(key) + " out of range [0, " +
                            std::to_string(model_->nkey) + ")");
    }
    mj_resetDataKeyframe(model_.get(), data_.get(), key);
  } else {
    mj_resetData(model_.get(), data_.get());
  }
  pushes_.clear();
  push_applied_W_.clear();
  seen_.fill(0);
  warnings_total_ = WarningCounts{};
  mj_forward(model_.get(), data_.get());
  collect_warnings();
}

void Simulation::forward() { mj_forward(model_.get(), data_.get()); }

void Simulation::schedule_push(const Push& push) {
  if (push.body < 0 || push.body >= model_->nbody) {
    throw InvalidArgument("push: body id " + std::to_string(push.body) + " out of range [0, " +
                          std::to_string(model_->nbody) + ")");
  }
  if (!(push.duration_s > 0.0) || !std::isfinite(push.duration_s)) {
    throw InvalidArgument("push: duration_s must be > 0, got " + std::to_string(push.duration_s));
  }
  if (!push.force_W.allFinite() || !std::isfinite(push.start_s)) {
    throw InvalidArgument("push: force and start time must be finite");
  }
  pushes_.push_back(push);
  push_applied_W_.push_back(Eigen::Vector3d::Zero());
}

void Simulation::apply_pushes() {
  const double t = data_->time;
  for (size_t i = 0; i < pushes_.size(); ++i) {
    const Push& p = pushes_[i];
    // Active on [start, start + duration): exactly round(duration / dt) steps.
    const bool active = t >= p.start_s - 0.5 * model_->opt.timestep &&
                        t < p.start_s + p.duration_s - 0.5 * model_->opt.timestep;
    const Eigen::Vector3d want = active ? p.force_W : Eigen::Vector3d::Zero();
    mjtNum* f = data_->xfrc_applied + 6 * p.body;  // [force(3), torque(3)] at the body CoM
    for (int k = 0; k < 3; ++k) f[k] += want[k] - push_applied_W_[i][k];
    push_applied_W_[i] = want;
  }
}

StepStatus Simulation::collect_warnings() {
  StepStatus status;
  for (int i = 0; i < mjNWARNING; ++i) {
    const int number = data_->warning[i].number;
    // mj_resetData (called by MuJoCo itself after bad qacc) zeroes the counters.
    const int fresh = number >= seen_[i] ? number - seen_[i] : number;
    status.new_warnings.count[i] = fresh;
    seen_[i] = number;
  }
  warnings_total_ += status.new_warnings;
  return status;
}

void Simulation::save(Checkpoint* c) const {
  c->data.save(*model_, *data_);
  c->pushes = pushes_;
  c->push_applied_W = push_applied_W_;
  c->seen = seen_;
  c->warnings = warnings_total_;
}

void Simulation::restore(const Checkpoint& c) {
  c.data.restore(*model_, *data_);
  pushes_ = c.pushes;
  push_applied_W_ = c.push_applied_W;
  seen_ = c.seen;
  warnings_total_ = c.warnings;
}

mjData& Simulation::synced_scratch() {
  copy_state(*model_, *data_, scratch_.get());
  mj_forward(model_.get(), scratch_.get());
  return *scratch_;
}

}  // namespace biodyn::sim
