#include "biodyn/controllers/foot_contact.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"

namespace biodyn::controllers {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

Matrix3d rotation_at(const mjtNum* xmat) {
  Matrix3d R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = xmat[3 * r + c];
  return R;
}

// A weld in tension by less than this fraction of body weight is numerical noise of the
// constraint solver (tolerance 1e-8), not adhesion.
constexpr double kTensionTolerance = 1e-6;

}  // namespace

const char* to_string(WeldMode mode) {
  switch (mode) {
    case WeldMode::kOff:
      return "off";
    case WeldMode::kHonest:
      return "honest";
    case WeldMode::kGlue:
      return "glue";
  }
  return "?";
}

WeldMode parse_weld_mode(const std::string& text, const std::string& field) {
  if (text == "off") return WeldMode::kOff;
  if (text == "honest") return WeldMode::kHonest;
  if (text == "glue") return WeldMode::kGlue;
  throw sim::InvalidArgument(field + ": must be 'off', 'honest' or 'glue', got '" + text + "'");
}

void FootWeldParams::validate() const {
  const auto fail = [](const std::string& f, const std::string& rule, double v) {
    throw sim::InvalidArgument("weld." + f + ": " + rule + ", got " + std::to_string(v));
  };
  if (!(engage_max_speed_m_s > 0))
    fail("engage_max_speed_m_s", "must be > 0", engage_max_speed_m_s);
  if (!(engage_max_angular_speed_rad_s > 0))
    fail("engage_max_angular_speed_rad_s", "must be > 0", engage_max_angular_speed_rad_s);
  if (engage_min_contacts < 1) fail("engage_min_contacts", "must be >= 1", engage_min_contacts);
  if (!(reengage_delay_s >= 0)) fail("reengage_delay_s", "must be >= 0", reengage_delay_s);
  if (!(min_load_fraction > 0 && min_load_fraction < 1))
    fail("min_load_fraction", "must be in (0, 1)", min_load_fraction);
  if (!(release_margin < engage_margin && engage_margin <= 1))
    fail("engage_margin", "must be in (release_margin, 1]", engage_margin);
}

FootWelds::FootWelds(const mjModel& m, const models::Rig& rig, FootWeldParams params)
    : params_(params),
      floor_geom_(rig.floor_geom()),
      qfrc_(static_cast<std::size_t>(m.nv)),
      jacobian_row_(static_cast<std::size_t>(m.nv)) {
  contacts_.reserve(static_cast<std::size_t>(m.nconmax));
  weight_ = rig.mass_kg() * std::abs(m.opt.gravity[2]);
  root_body_ = std::max(rig.pelvis(), 1);
  root_dof_ = m.body_dofadr[root_body_];
  params_.validate();
  if (params_.mode != WeldMode::kOff) {
    const std::string user = "foot welds (use a generated character, or --weld off)";
    rig.require_legs(user);
    rig.require_foot_welds(user);
  }
  for (int s = 0; s < 2; ++s) {
    const models::RigLeg& leg = rig.leg(s);
    Foot& f = feet_[static_cast<std::size_t>(s)];
    if (leg.foot_weld < 0 || leg.foot < 0 || floor_geom_ < 0 || !leg.has_sole)
      continue;  // off mode
    f.eq = leg.foot_weld;
    f.body = leg.foot;
    f.sole = leg.sole;
    for (int g = 0; g < m.ngeom; ++g) {
      if (m.geom_bodyid[g] == f.body)
        f.mu = std::max(m.geom_friction[3 * g], m.geom_friction[3 * floor_geom_]);
    }
  }
}

void FootWelds::set_mode(mjModel& m, WeldMode mode) {
  params_.mode = mode;
  if (mode == WeldMode::kOff) {
    for (Foot& f : feet_)
      if (f.eq >= 0) m.eq_active[f.eq] = 0;
  }
}

void FootWelds::reset(mjModel& m) {
  for (const Foot& f : feet_)
    if (f.eq >= 0) m.eq_active[f.eq] = 0;
  state_ = FootWeldState{};
}

bool FootWelds::active(const mjModel& m, int side) const {
  const Foot& f = feet_[static_cast<std::size_t>(side)];
  return f.eq >= 0 && m.eq_active[f.eq];
}

void FootWelds::set_stance(mjModel& m, int side, bool stance) {
  const Foot& f = feet_[static_cast<std::size_t>(side)];
  state_.stance[static_cast<std::size_t>(side)] = stance;
  if (!stance && f.eq >= 0) m.eq_active[f.eq] = 0;  // lift-off
}

void FootWelds::engage(mjModel& m, const mjData& d, const Foot& f) {
  // Anchor: the sole centre. eq_data (2.2.2): [0:3] anchor in body2 (world) frame, [3:6] the
  // same point in body1 (foot) frame, [6:10] neg(q_foot) * q_world, [10] torque scale.
  const Vector3d p_B = f.sole.centre_B();
  const Vector3d p_W = sim::vec3_at(d.xpos + 3 * f.body) + rotation_at(d.xmat + 9 * f.body) * p_B;
  mjtNum* data = m.eq_data + mjNEQDATA * f.eq;
  for (int k = 0; k < 3; ++k) {
    data[k] = p_W[k];
    data[3 + k] = p_B[k];
  }
  mjtNum q_neg[4];
  mju_negQuat(q_neg, d.xquat + 4 * f.body);
  for (int k = 0; k < 4; ++k) data[6 + k] = q_neg[k];
  m.eq_active[f.eq] = 1;
}

void FootWelds::engage_at_strikes(mjModel& m, const mjData& d) {
  if (params_.mode == WeldMode::kOff) return;
  for (std::size_t side = 0; side < 2; ++side) {
    const Foot& f = feet_[side];
    if (f.eq < 0 || !state_.stance[side] || m.eq_active[f.eq]) continue;
    if (d.time < state_.released_at_s[side] + params_.reengage_delay_s) continue;
    if (sim::floor_contact_count(m, d, floor_geom_, f.body) < params_.engage_min_contacts) continue;
    // Honest: only weld a foot whose contacts alone already hold it well inside the cone, so
    // the weld shares load the contacts could carry and switching it on changes nothing.
    if (params_.mode == WeldMode::kHonest && state_.wrench[side].margin < params_.engage_margin)
      continue;
    mjtNum vel[6];  // [angular, linear] in world frame
    mj_objectVelocity(&m, &d, mjOBJ_BODY, f.body, vel, 0);
    const double w = std::sqrt(vel[0] * vel[0] + vel[1] * vel[1] + vel[2] * vel[2]);
    const double v = std::sqrt(vel[3] * vel[3] + vel[4] * vel[4] + vel[5] * vel[5]);
    if (v > params_.engage_max_speed_m_s || w > params_.engage_max_angular_speed_rad_s) continue;
    engage(m, d, f);
  }
}

int FootWelds::measure(const mjModel& m, const mjData& d) {
  int in_tension = -1;
  sim::floor_contacts(m, d, floor_geom_, &contacts_);
  for (int s = 0; s < 2; ++s) {
    const Foot& f = feet_[static_cast<std::size_t>(s)];
    WeldWrench& out = state_.wrench[static_cast<std::size_t>(s)];
    out = WeldWrench{};
    if (f.eq < 0) continue;
    const Matrix3d R_f = rotation_at(d.xmat + 9 * f.body);
    const Vector3d c_W = sim::vec3_at(d.xpos + 3 * f.body) + R_f * f.sole.centre_B();
    bool has_rows = false;  // a weld switched on in this step acts from the next one
    if (m.eq_active[f.eq]) {
      // Generalized force of this weld's rows; on the free root it is the net wrench.
      std::fill(qfrc_.begin(), qfrc_.end(), 0.0);
      for (int r = 0; r < d.nefc; ++r) {
        if (d.efc_type[r] != mjCNSTR_EQUALITY || d.efc_id[r] != f.eq) continue;
        has_rows = true;
        sim::efc_jacobian_row(m, d, r, jacobian_row_.data());
        for (int i = 0; i < m.nv; ++i)
          qfrc_[static_cast<std::size_t>(i)] +=
              jacobian_row_[static_cast<std::size_t>(i)] * d.efc_force[r];
      }
      const auto q = [&](int i) { return qfrc_[static_cast<std::size_t>(root_dof_ + i)]; };
      out.force_W = Vector3d(q(0), q(1), q(2));
      const Vector3d tau_root = rotation_at(d.xmat + 9 * root_body_) * Vector3d(q(3), q(4), q(5));
      out.moment_W = tau_root + (sim::vec3_at(d.xpos + 3 * root_body_) - c_W).cross(out.force_W);
    }
    // Together with the foot's (and toes') contacts, is it a wrench the ground could give
    // through the sole? Only the net wrench moves the foot, and any net wrench inside this
    // contact wrench cone can be produced by unilateral frictional contact alone.
    out.ground_force_W = out.force_W;
    out.ground_moment_W = out.moment_W;
    for (const sim::FloorContact& c : contacts_) {
      if (c.body != f.body && m.body_parentid[c.body] != f.body) continue;
      const Vector3d fc = c.normal_force * c.normal_W + c.tangential_force_W;
      out.ground_force_W += fc;
      // Lever arm in the sole plane: the contact point sits inside the soft penetration,
      // a fraction of a millimetre below the sole, which is not a lever of the foot.
      Vector3d arm_B = R_f.transpose() * (c.position_W - c_W);
      arm_B.z() = 0;
      out.ground_moment_W += (R_f * arm_B).cross(fc);
    }
    const Vector3d F = R_f.transpose() * out.ground_force_W;
    const Vector3d M = R_f.transpose() * out.ground_moment_W;
    const double hx = (f.sole.x_max - f.sole.x_min) / 2, hy = (f.sole.y_max - f.sole.y_min) / 2;
    const double r = std::hypot(hx, hy);
    const double ft = std::hypot(F.x(), F.y());
    const double excess =
        std::max({-F.z(), ft - f.mu * F.z(), (std::abs(M.y()) - hx * F.z()) / hx,
                  (std::abs(M.x()) - hy * F.z()) / hy, (std::abs(M.z()) - f.mu * F.z() * r) / r});
    out.tension_excess_N = std::max(0.0, excess);
    out.tension = has_rows && excess > kTensionTolerance * weight_;
    // Margin inside the cone, 1 = centred and loaded, <= 0 = at or past an edge.
    const double load = params_.min_load_fraction * weight_;
    out.margin = F.z() <= 0
                     ? -1.0
                     : std::min({(F.z() - load) / load, 1.0 - std::abs(M.y()) / (hx * F.z()),
                                 1.0 - std::abs(M.x()) / (hy * F.z()), 1.0 - ft / (f.mu * F.z()),
                                 1.0 - std::abs(M.z()) / (f.mu * F.z() * r)});
    out.margin = std::min(out.margin, 1.0);
    if (out.tension && in_tension < 0) in_tension = s;
  }
  return in_tension;
}

void FootWelds::release_near_edges(mjModel& m, double t) {
  if (params_.mode != WeldMode::kHonest) return;
  for (int s = 0; s < 2; ++s) {
    const Foot& f = feet_[static_cast<std::size_t>(s)];
    if (f.eq >= 0 && m.eq_active[f.eq] &&
        state_.wrench[static_cast<std::size_t>(s)].margin < params_.release_margin) {
      m.eq_active[f.eq] = 0;
      state_.released_at_s[static_cast<std::size_t>(s)] = t;
    }
  }
}

void FootWelds::release_for_tension(mjModel& m, int side, double t) {
  const Foot& f = feet_[static_cast<std::size_t>(side)];
  if (f.eq >= 0) m.eq_active[f.eq] = 0;
  state_.released_at_s[static_cast<std::size_t>(side)] = t;
}

}  // namespace biodyn::controllers
