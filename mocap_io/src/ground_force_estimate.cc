// Ground reaction forces from kinematics (ground_force_estimate.h).
#include "biodyn/mocap_io/ground_force_estimate.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "biodyn/models/rig.h"
#include "biodyn/muscles/box_qp.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/queries.h"

namespace biodyn::mocap_io {
namespace {

using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;

/// Foot-flat calibration (foot_flat_floors): a foot whose lowest point is within this of the
/// motion's floor may be standing; its slowest fraction of such frames is where it stands flat.
constexpr double kNearFloor_m = 0.05;
constexpr double kFlatFrameFraction = 0.1;
/// AMMR's linear strength profile: full strength below these fractions of h_max and v_max.
constexpr double kFullHeightFraction = 0.8, kFullSpeedFraction = 0.15;
/// m: a point this close to its floor (or below it) may push at any speed.
constexpr double kTouching_m = 0.01;
/// Friction-pyramid edges per point: n + mu t for t = +x, -x, +y, -y.
constexpr int kEdges = 4;
/// N: a foot with less vertical force has no meaningful centre of pressure.
constexpr double kMinCopLoad_N = 20.0;

/// The first box geom of `body`, or -1.
int box_geom(const mjModel& m, int body) {
  for (int g = 0; g < m.ngeom; ++g) {
    if (m.geom_bodyid[g] == body && m.geom_type[g] == mjGEOM_BOX) return g;
  }
  return -1;
}

/// Point of box geom `g`'s bottom face at (fx, fy) of its half-lengths, in its body's frame.
Vector3d box_bottom_point(const mjModel& m, int g, double fx, double fy) {
  mjtNum local[3] = {fx * m.geom_size[3 * g], fy * m.geom_size[3 * g + 1], -m.geom_size[3 * g + 2]};
  mjtNum rotated[3];
  mju_rotVecQuat(rotated, local, m.geom_quat + 4 * g);
  return Vector3d(m.geom_pos[3 * g], m.geom_pos[3 * g + 1], m.geom_pos[3 * g + 2]) +
         Vector3d(rotated[0], rotated[1], rotated[2]);
}

/// Linear ramp: 1 at or below `full`, 0 at or above `zero`.
double ramp(double x, double full, double zero) {
  if (x <= full) return 1.0;
  if (x >= zero) return 0.0;
  return (zero - x) / (zero - full);
}

/// The q-quantile of `v` (copied).
double quantile(std::vector<double> v, double q) {
  const size_t k = static_cast<size_t>(std::clamp(q, 0.0, 1.0) * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

/// Each point's floor height: its median height over its foot's stillest frames on the floor
/// (the slowest kFlatFrameFraction of the frames whose lowest point is within kNearFloor_m of
/// the motion's floor). A sole point is on the floor when its foot stands flat: this absorbs
/// a model sole that the IK fit leaves pitched or floating against the real one (walking5's
/// heels sit 7 cm above its toes at mid-stance). A foot never near the floor gets the motion's
/// floor (the `quantile` of every point's height).
std::vector<double> foot_flat_floors(const std::vector<SoleContactPoint>& points,
                                     const MatrixXd& position, const MatrixXd& speed,
                                     double quantile_level) {
  const int frames = static_cast<int>(position.rows()), np = static_cast<int>(points.size());
  std::vector<double> all;
  for (int c = 0; c < np; ++c) {
    for (int f = 0; f < frames; ++f) all.push_back(position(f, 3 * c + 2));
  }
  const double floor = quantile(all, quantile_level);
  std::vector<double> floors(static_cast<size_t>(np), floor);
  for (int side = 0; side < 2; ++side) {
    std::vector<std::pair<double, int>> still;  // (foot speed, frame) of frames on the floor
    for (int f = 0; f < frames; ++f) {
      double lowest = std::numeric_limits<double>::infinity(), foot_speed = 0;
      int n = 0;
      for (int c = 0; c < np; ++c) {
        if (points[static_cast<size_t>(c)].side != side) continue;
        lowest = std::min(lowest, position(f, 3 * c + 2));
        foot_speed += speed(f, c);
        ++n;
      }
      if (n > 0 && lowest < floor + kNearFloor_m) still.emplace_back(foot_speed / n, f);
    }
    if (still.empty()) continue;
    std::sort(still.begin(), still.end());  // by speed, then frame: deterministic
    const size_t keep = std::max<size_t>(
        1, static_cast<size_t>(kFlatFrameFraction * static_cast<double>(still.size())));
    for (int c = 0; c < np; ++c) {
      if (points[static_cast<size_t>(c)].side != side) continue;
      std::vector<double> z;
      for (size_t i = 0; i < keep; ++i) z.push_back(position(still[i].second, 3 * c + 2));
      floors[static_cast<size_t>(c)] = quantile(z, 0.5);
    }
  }
  return floors;
}

/// The DOFs a sole point's force can reach: the root's and the legs' (ancestors of the points'
/// bodies), in DOF order.
std::vector<int> reachable_dofs(const mjModel& m, const std::vector<SoleContactPoint>& points) {
  std::vector<char> used(static_cast<size_t>(m.nv), 0);
  for (const SoleContactPoint& p : points) {
    for (int b = p.body; b > 0; b = m.body_parentid[b]) {
      for (int k = 0; k < m.body_dofnum[b]; ++k)
        used[static_cast<size_t>(m.body_dofadr[b] + k)] = 1;
    }
  }
  std::vector<int> dofs;
  for (int v = 0; v < m.nv; ++v) {
    if (used[static_cast<size_t>(v)]) dofs.push_back(v);
  }
  return dofs;
}

/// Per frame: each point's world position and its translational Jacobian restricted to `dofs`.
struct PointKinematics {
  std::vector<MatrixXd> jacobian;  // per frame: (3 points) x dofs
  MatrixXd position;               // frames x (3 points)
  MatrixXd speed;                  // frames x points, m/s
};

PointKinematics point_kinematics(const mjModel& m, const MatrixXd& qpos, const MatrixXd& qvel,
                                 const std::vector<SoleContactPoint>& points,
                                 const std::vector<int>& dofs) {
  const int frames = static_cast<int>(qpos.rows()), np = static_cast<int>(points.size());
  const int nd = static_cast<int>(dofs.size());
  sim::Data data(m);
  mjData* d = data.get();
  PointKinematics k;
  k.jacobian.assign(static_cast<size_t>(frames), MatrixXd(3 * np, nd));
  k.position.resize(frames, 3 * np);
  k.speed.resize(frames, np);
  std::vector<mjtNum> jacp(static_cast<size_t>(3 * m.nv));
  for (int f = 0; f < frames; ++f) {
    for (int i = 0; i < m.nq; ++i) d->qpos[i] = qpos(f, i);
    mj_kinematics(&m, d);
    mj_comPos(&m, d);
    for (int c = 0; c < np; ++c) {
      const SoleContactPoint& p = points[static_cast<size_t>(c)];
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> r(d->xmat + 9 * p.body);
      const Vector3d world =
          Vector3d(d->xpos[3 * p.body], d->xpos[3 * p.body + 1], d->xpos[3 * p.body + 2]) +
          r * p.pos_B;
      k.position.row(f).segment<3>(3 * c) = world.transpose();
      mj_jac(&m, d, jacp.data(), nullptr, world.data(), p.body);
      Vector3d v = Vector3d::Zero();
      for (int a = 0; a < 3; ++a) {
        for (int j = 0; j < nd; ++j) {
          const double jj = jacp[static_cast<size_t>(a * m.nv + dofs[static_cast<size_t>(j)])];
          k.jacobian[static_cast<size_t>(f)](3 * c + a, j) = jj;
          v(a) += jj * qvel(f, dofs[static_cast<size_t>(j)]);
        }
      }
      k.speed(f, c) = v.head<2>().norm();
    }
  }
  return k;
}

/// One pass of the per-frame QP over the frames in the order given; returns frames x (points x
/// edges) forces as fractions of the point strength.
class FrameQp {
 public:
  FrameQp(const std::vector<MatrixXd>& jacobian, const MatrixXd& required_dofs,
          const VectorXd& row_weight, const MatrixXd& activation, double strength_N,
          const GroundForceEstimateOptions& o)
      : jacobian_(jacobian),
        required_(required_dofs),
        row_weight_(row_weight),
        activation_(activation),
        o_(o),
        np_(static_cast<int>(activation.cols())),
        n_(kEdges * np_),
        qp_(n_),
        edges_(3, kEdges) {
    edges_ << o.friction, -o.friction, 0, 0,  //
        0, 0, o.friction, -o.friction,        //
        1, 1, 1, 1;
    edges_ *= strength_N;  // a variable of 1 is the point's full strength along the edge
  }

  MatrixXd run(bool forward) {
    const int frames = static_cast<int>(required_.rows());
    MatrixXd x_all = MatrixXd::Zero(frames, n_);
    VectorXd x = VectorXd::Zero(n_), last = VectorXd::Zero(n_), lo = VectorXd::Zero(n_), hi(n_);
    MatrixXd a(required_.cols(), n_), h(n_, n_);
    VectorXd g(n_);
    std::vector<int> bounds(static_cast<size_t>(n_), -1);
    for (int step = 0; step < frames; ++step) {
      const int f = forward ? step : frames - 1 - step;
      const MatrixXd& jac = jacobian_[static_cast<size_t>(f)];
      for (int c = 0; c < np_; ++c) {
        // Generalised force of edge k at point c: J_c^T e_k.
        a.middleCols<kEdges>(kEdges * c) = jac.middleRows<3>(3 * c).transpose() * edges_;
        hi.segment<kEdges>(kEdges * c).setConstant(activation_(f, c));
      }
      const double smooth = step == 0 ? 0.0 : o_.smooth_weight;
      h.noalias() = a.transpose() * row_weight_.asDiagonal() * a;
      h.diagonal().array() += o_.effort_weight + smooth;
      g.noalias() = -(a.transpose() * row_weight_.asDiagonal() * required_.row(f).transpose());
      g -= smooth * last;
      qp_.solve(h, g, lo, hi, &x, bounds.data());
      for (int i = 0; i < n_; ++i) bounds[static_cast<size_t>(i)] = qp_.bound(i);
      x_all.row(f) = x.transpose();
      last = x;
    }
    return x_all;
  }

  const MatrixXd& edges() const { return edges_; }

 private:
  const std::vector<MatrixXd>& jacobian_;
  const MatrixXd& required_;
  const VectorXd& row_weight_;
  const MatrixXd& activation_;
  const GroundForceEstimateOptions& o_;
  int np_, n_;
  muscles::BoxQp qp_;
  MatrixXd edges_;  // 3 x edges, world, N per unit variable
};

/// Per side: total force, centre of pressure on the floor and vertical free moment at frame f.
void foot_resultants(const GroundForceEstimate& e, const MatrixXd& point_force,
                     const MatrixXd& position, int f, GroundForceEstimate* out) {
  for (int side = 0; side < 2; ++side) {
    Vector3d force = Vector3d::Zero();
    double floor_weighted = 0;
    for (size_t c = 0; c < e.points.size(); ++c) {
      if (e.points[c].side != side) continue;
      const Vector3d fc = point_force.row(f).segment<3>(3 * static_cast<int>(c)).transpose();
      force += fc;
      floor_weighted += fc.z() * e.floor_z_m[c];
    }
    out->force_N[static_cast<size_t>(side)].row(f) = force.transpose();
    Vector3d cop = Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
    double free_moment = 0;
    if (force.z() > kMinCopLoad_N) {
      const double z0 = floor_weighted / force.z();
      // The point on the floor plane z0 about which the forces have no horizontal moment.
      double mx = 0, my = 0;
      for (size_t c = 0; c < e.points.size(); ++c) {
        if (e.points[c].side != side) continue;
        const Vector3d fc = point_force.row(f).segment<3>(3 * static_cast<int>(c)).transpose();
        const Vector3d p = position.row(f).segment<3>(3 * static_cast<int>(c)).transpose();
        mx += p.x() * fc.z() - (p.z() - z0) * fc.x();
        my += p.y() * fc.z() - (p.z() - z0) * fc.y();
      }
      cop = Vector3d(mx / force.z(), my / force.z(), z0);
      for (size_t c = 0; c < e.points.size(); ++c) {
        if (e.points[c].side != side) continue;
        const Vector3d fc = point_force.row(f).segment<3>(3 * static_cast<int>(c)).transpose();
        const Vector3d p = position.row(f).segment<3>(3 * static_cast<int>(c)).transpose();
        free_moment += (p - cop).cross(fc).z();
      }
    }
    out->cop_m[static_cast<size_t>(side)].row(f) = cop.transpose();
    out->free_moment_Nm[static_cast<size_t>(side)](f) = free_moment;
  }
}

}  // namespace

std::vector<SoleContactPoint> sole_contact_points(const mjModel& m) {
  const models::Rig rig(m);
  std::vector<SoleContactPoint> points;
  for (int side : {models::kLeft, models::kRight}) {
    const models::RigLeg& leg = rig.leg(side);
    const int foot_box = leg.foot < 0 ? -1 : box_geom(m, leg.foot);
    if (foot_box < 0) {
      throw models::RigError("ground force estimate: the model has no " +
                             std::string(side == models::kLeft ? "left" : "right") +
                             " foot with a box sole (a generated character's foot_l/foot_r)");
    }
    const char* suffix = models::kSideSuffix[side];
    // Body frames: x forward, y left; the left foot's medial edge is at -y, the right's at +y.
    const double medial = side == models::kLeft ? -1.0 : 1.0;
    auto add = [&](const std::string& name, int body, const Vector3d& pos) {
      points.push_back({name + suffix, side, body, pos});
    };
    for (const auto& [x, where] :
         {std::pair<double, const char*>{-1.0, "heel"}, {0.0, "midfoot"}, {1.0, "metatarsal"}}) {
      add(std::string(where) + "_medial", leg.foot, box_bottom_point(m, foot_box, x, medial));
      add(std::string(where) + "_lateral", leg.foot, box_bottom_point(m, foot_box, x, -medial));
    }
    const int toes_box = leg.toes < 0 ? -1 : box_geom(m, leg.toes);
    if (toes_box >= 0) {
      add("toe_medial", leg.toes, box_bottom_point(m, toes_box, 1.0, medial));
      add("toe_lateral", leg.toes, box_bottom_point(m, toes_box, 1.0, -medial));
    }
  }
  return points;
}

GroundForceEstimate estimate_ground_forces(const mjModel& m, const MatrixXd& qpos,
                                           const MatrixXd& qvel, const MatrixXd& required,
                                           const GroundForceEstimateOptions& o) {
  const int frames = static_cast<int>(qpos.rows());
  if (qvel.rows() != frames || required.rows() != frames || qpos.cols() != m.nq ||
      qvel.cols() != m.nv || required.cols() != m.nv) {
    throw sim::InvalidArgument("ground force estimate: qpos, qvel and forces must have " +
                               std::to_string(frames) + " rows and the model's nq/nv columns");
  }
  if (frames < 1) throw sim::InvalidArgument("ground force estimate: no frames");
  const models::Rig rig(m);
  rig.require_legs("ground force estimate");
  GroundForceEstimate e;
  e.points = sole_contact_points(m);
  const int np = static_cast<int>(e.points.size());
  const std::vector<int> dofs = reachable_dofs(m, e.points);
  const PointKinematics k = point_kinematics(m, qpos, qvel, e.points, dofs);

  // Each point's floor (foot_flat_floors), and its strength ramp per frame (AMMR's linear
  // profile).
  e.floor_z_m = foot_flat_floors(e.points, k.position, k.speed, o.floor_quantile);
  e.activation.resize(frames, np);
  e.height_m.resize(frames, np);
  e.speed_mps = k.speed;
  for (int c = 0; c < np; ++c) {
    for (int f = 0; f < frames; ++f) {
      const double h = k.position(f, 3 * c + 2) - e.floor_z_m[static_cast<size_t>(c)];
      e.height_m(f, c) = h;
      // A point at or below its floor touches it whatever its speed (a sliding point still
      // carries load; the pyramid bounds its friction): the speed gate only keeps a swing foot
      // skimming the floor from taking load. Continuous over kTouching_m.
      const double slow =
          ramp(k.speed(f, c), kFullSpeedFraction * o.contact_speed_mps, o.contact_speed_mps);
      e.activation(f, c) = ramp(h, kFullHeightFraction * o.contact_height_m, o.contact_height_m) *
                           std::max(slow, ramp(h, 0.0, kTouching_m));
    }
  }

  // Costs in body-weight units: forces / (m g), moments and torques / (m g leg length).
  double mass = 0;
  for (int b = 1; b < m.nbody; ++b) mass += m.body_mass[b];
  const double weight = mass * std::sqrt(mju_dot(m.opt.gravity, m.opt.gravity, 3));
  if (!(weight > 0)) {
    throw sim::InvalidArgument("ground force estimate: the model has no weight (mass " +
                               std::to_string(mass) + " kg, gravity off?)");
  }
  const models::RigLeg& leg = rig.leg(models::kLeft);
  const double moment_scale = weight * (leg.thigh_length_m + leg.shank_length_m);
  const int root_dof = rig.root_joint() >= 0 ? m.jnt_dofadr[rig.root_joint()] : -1;
  std::vector<double> tau_max = sim::motor_limits_per_dof(m);
  for (double& t : tau_max) t = t > 0 ? t : moment_scale;  // no motor: the body-weight scale
  const int nd = static_cast<int>(dofs.size());
  VectorXd row_weight(nd);
  MatrixXd required_dofs(frames, nd);
  for (int j = 0; j < nd; ++j) {
    const int v = dofs[static_cast<size_t>(j)];
    const int root_row = root_dof >= 0 ? v - root_dof : -1;
    if (root_row >= 0 && root_row < 3) {
      row_weight(j) = o.root_weight / (weight * weight);
    } else if (root_row >= 3 && root_row < 6) {
      row_weight(j) = o.root_weight / (moment_scale * moment_scale);
    } else {
      // Relative to the joint's strength (its motor's tau_max): the ground takes load where it
      // spares the weak joints most (Fluit 2014's muscle effort, at the joint level).
      const double strength = tau_max[static_cast<size_t>(v)];
      row_weight(j) = o.joint_weight / (strength * strength);
    }
    required_dofs.col(j) = required.col(v);
  }

  // Forward and backward passes, averaged: the smoothing term then lags neither way.
  const double strength = o.point_strength_bw * weight;
  FrameQp qp(k.jacobian, required_dofs, row_weight, e.activation, strength, o);
  const MatrixXd x = 0.5 * (qp.run(true) + qp.run(false));

  // Point forces (world), the feet's resultants and the generalised force.
  MatrixXd point_force(frames, 3 * np);
  for (int c = 0; c < np; ++c) {
    point_force.middleCols<3>(3 * c) = x.middleCols<kEdges>(kEdges * c) * qp.edges().transpose();
  }
  for (int side = 0; side < 2; ++side) {
    e.force_N[static_cast<size_t>(side)].resize(frames, 3);
    e.cop_m[static_cast<size_t>(side)].resize(frames, 3);
    e.free_moment_Nm[static_cast<size_t>(side)].resize(frames);
  }
  e.generalized_force = MatrixXd::Zero(frames, m.nv);
  for (int f = 0; f < frames; ++f) {
    foot_resultants(e, point_force, k.position, f, &e);
    const VectorXd on_dofs =
        k.jacobian[static_cast<size_t>(f)].transpose() * point_force.row(f).transpose();
    for (int j = 0; j < nd; ++j) e.generalized_force(f, dofs[static_cast<size_t>(j)]) = on_dofs(j);
  }
  return e;
}

}  // namespace biodyn::mocap_io
