#include "biodyn/scenarios/drop.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"

namespace biodyn::scenarios {
namespace {

bool all_finite(const mjtNum* v, int n) {
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(v[i])) return false;
  }
  return true;
}

double max_body_speed(const mjModel& m, const mjData& d) {
  double fastest = 0;
  mjtNum vel[6];
  for (int b = 1; b < m.nbody; ++b) {
    mj_objectVelocity(&m, &d, mjOBJ_BODY, b, vel, 0);
    fastest = std::max(fastest, std::sqrt(vel[3] * vel[3] + vel[4] * vel[4] + vel[5] * vel[5]));
  }
  return fastest;
}

}  // namespace

void DropParams::validate() const {
  const auto fail = [](const char* field, const char* rule, double value) {
    std::ostringstream msg;
    msg << field << ": " << rule << ", got " << value;
    throw sim::InvalidArgument(msg.str());
  };
  if (!(duration_s > 0) || !std::isfinite(duration_s))
    fail("duration", "must be > 0 s", duration_s);
  if (!(rest_speed > 0)) fail("rest_speed", "must be > 0 m/s", rest_speed);
}

DropResult run_drop(sim::Simulation* sim, const DropParams& params,
                    const std::function<void(double)>& progress) {
  params.validate();
  const mjModel& m = sim->model();
  mjData& d = sim->data();
  mju_zero(d.ctrl, m.nu);
  sim->forward();
  DropResult r;
  const models::Rig rig(m);
  rig.require_root("drop");
  const int pelvis = rig.pelvis();
  r.pelvis_height_start_m = d.xpos[3 * pelvis + 2];
  r.com_height_start_m = sim::center_of_mass(m, d).position_W.z();
  r.com_height_min_m = r.com_height_start_m;
  r.energy_start_J = sim::mechanical_energy(m, d);
  double running_min_energy = r.energy_start_J;
  const int steps = static_cast<int>(std::lround(params.duration_s / m.opt.timestep));
  const int report_every = std::max(1, steps / 100);
  const double start_time = d.time;
  double last_moving_time = d.time;
  for (int s = 0; s < steps; ++s) {
    sim->step([&](const mjModel& model, mjData& data) {
      // After mj_step1: positions, velocities and the mass matrix belong to this state.
      const double energy = sim::mechanical_energy(model, data);
      r.max_energy_rise_J = std::max(r.max_energy_rise_J, energy - running_min_energy);
      running_min_energy = std::min(running_min_energy, energy);
      const double com_z = sim::center_of_mass(model, data).position_W.z();
      r.com_height_min_m = std::min(r.com_height_min_m, com_z);
      if (r.collapse_time_s < 0 && com_z < 0.5 * r.com_height_start_m) {
        r.collapse_time_s = data.time - start_time;
      }
      if (max_body_speed(model, data) > params.rest_speed) last_moving_time = data.time;
    });
    if (!all_finite(d.qpos, m.nq) || !all_finite(d.qvel, m.nv) || !all_finite(d.qacc, m.nv)) {
      r.finite = false;
    }
    ++r.steps;
    if (progress && (s % report_every == 0 || s + 1 == steps)) {
      progress(static_cast<double>(s + 1) / steps);
    }
  }
  sim->forward();
  r.simulated_s = d.time - start_time;
  r.pelvis_height_end_m = d.xpos[3 * pelvis + 2];
  r.com_height_end_m = sim::center_of_mass(m, d).position_W.z();
  r.energy_end_J = sim::mechanical_energy(m, d);
  r.max_energy_rise_J = std::max(r.max_energy_rise_J, r.energy_end_J - running_min_energy);
  if (max_body_speed(m, d) <= params.rest_speed) r.rest_time_s = last_moving_time - start_time;
  r.warnings = sim->warnings();
  return r;
}

}  // namespace biodyn::scenarios
