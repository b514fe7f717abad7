// The character's own BVH (retarget.h: character_bvh): one joint per segment, rotations from
// MuJoCo's kinematics of the qpos, decomposed into Euler angles in gimbal-safe orders.
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <functional>

#include "biodyn/mocap_io/retarget.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/units.h"

namespace biodyn::mocap_io {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using sim::InvalidArgument;

/// |sin| of the middle Euler angle beyond which the decomposition is treated as gimbal-locked.
constexpr double kGimbalLockSin = 1.0 - 1e-12;

/// Angles (a, b, c) with R = R_i(a) R_j(b) R_k(c) (intrinsic, in that order) for distinct axes
/// i, j, k; the middle angle in [-pi/2, pi/2].
Vector3d euler_intrinsic(const Matrix3d& r, int i, int j, int k) {
  const bool cyclic = (j == (i + 1) % 3);
  const double s = cyclic ? 1.0 : -1.0;
  const double sb = std::clamp(s * r(i, k), -1.0, 1.0);
  const double b = std::asin(sb);
  if (std::abs(sb) > kGimbalLockSin) {  // c := 0; R = R_i(a) R_j(b): column j is R_i(a) e_j
    return Vector3d(std::atan2(s * r(k, j), r(j, j)), b, 0.0);
  }
  return Vector3d(std::atan2(-s * r(j, k), r(k, k)), b, std::atan2(-s * r(i, j), r(i, i)));
}

BvhChannel rotation_channel(int axis) {
  return axis == 0 ? BvhChannel::kXrotation
                   : (axis == 1 ? BvhChannel::kYrotation : BvhChannel::kZrotation);
}

/// The file axes of the world's directions and the rotation channels' orders (character_bvh).
struct BvhAxes {
  Matrix3d a;                      ///< file_to_world: file axes -> world
  Matrix3d a_t;                    ///< its transpose: world -> file axes
  std::array<int, 3> root_order;   ///< file axes of the root's rotation channels, in order
  std::array<int, 3> joint_order;  ///< file axes of the other joints' rotation channels
};

BvhAxes bvh_axes(UpAxis up_axis) {
  // File axes of the world's forward (x), lateral (y) and up (z) directions.
  BvhAxes ax;
  ax.a = file_to_world(up_axis);
  ax.a_t = ax.a.transpose();
  int axis_of[3];
  for (int w = 0; w < 3; ++w) {
    Eigen::Index axis = 0;
    ax.a_t.col(w).cwiseAbs().maxCoeff(&axis);
    axis_of[w] = static_cast<int>(axis);
  }
  const int fwd = axis_of[0], lat = axis_of[1], up = axis_of[2];
  ax.root_order = {up, lat, fwd};   // heading first, pitch in the middle
  ax.joint_order = {fwd, up, lat};  // twist about the vertical in the middle
  return ax;
}

/// The character's hierarchy into out->joints, depth first (parents before children in
/// c.segments): one joint per segment at its origin, an End Site after each leaf. Returns the
/// segment of each BVH joint (-1 for an end site); `channels` receives the channel count.
std::vector<int> add_hierarchy(const models::Character& c, const BvhAxes& ax,
                               double metres_per_unit, BvhMotion* out, int* channels) {
  std::vector<int> order;  // segment index per BVH joint, -1 for an end site
  *channels = 0;
  const std::function<void(size_t, int)> visit = [&](size_t s, int parent_joint) {
    const models::Segment& seg = c.segments[s];
    BvhJoint j;
    j.name = seg.name;
    j.parent = parent_joint;
    const Vector3d rel =
        parent_joint < 0 ? Vector3d::Zero() : Vector3d(seg.origin_W - c.find(seg.parent)->origin_W);
    j.offset = ax.a_t * rel / metres_per_unit;
    if (parent_joint < 0) {
      j.channels = {BvhChannel::kXposition, BvhChannel::kYposition, BvhChannel::kZposition};
      for (int axis : ax.root_order) j.channels.push_back(rotation_channel(axis));
    } else {
      for (int axis : ax.joint_order) j.channels.push_back(rotation_channel(axis));
    }
    j.first_channel = *channels;
    *channels += static_cast<int>(j.channels.size());
    const int me = static_cast<int>(out->joints.size());
    out->joints.push_back(j);
    order.push_back(static_cast<int>(s));
    bool leaf = true;
    for (size_t k = 0; k < c.segments.size(); ++k) {
      if (c.segments[k].parent == seg.name) {
        leaf = false;
        visit(k, me);
      }
    }
    if (leaf) {
      BvhJoint e;
      e.name = seg.name + "_end";
      e.parent = me;
      e.end_site = true;
      e.offset = ax.a_t * (segment_end_W(seg) - seg.origin_W) / metres_per_unit;
      e.first_channel = *channels;
      out->joints.push_back(e);
      order.push_back(-1);
    }
  };
  visit(0, -1);
  return order;
}

/// Row f of out->values from the kinematics in `d`: the root's position, then each joint's
/// rotation relative to its parent's as Euler angles (degrees) in its channel order.
void write_frame(const BvhAxes& ax, const std::vector<int>& body, const std::vector<int>& order,
                 double metres_per_unit, const mjData& d, Eigen::Index f, BvhMotion* out) {
  for (size_t bj = 0; bj < out->joints.size(); ++bj) {
    const int s = order[bj];
    if (s < 0) continue;
    const BvhJoint& j = out->joints[bj];
    const int b = body[static_cast<size_t>(s)];
    const Matrix3d r_wb =
        Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(d.xmat + 9 * b);
    Matrix3d local;
    int col = j.first_channel;
    if (j.parent < 0) {
      const Vector3d p = ax.a_t * Vector3d(d.xpos + 3 * b) / metres_per_unit;
      for (int k = 0; k < 3; ++k) out->values(f, col++) = p(k);
      local = ax.a_t * r_wb * ax.a;
    } else {
      const int pb = body[static_cast<size_t>(order[static_cast<size_t>(j.parent)])];
      const Matrix3d r_wp =
          Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(d.xmat + 9 * pb);
      local = ax.a_t * r_wp.transpose() * r_wb * ax.a;
    }
    const std::array<int, 3>& ord = j.parent < 0 ? ax.root_order : ax.joint_order;
    const Vector3d e = euler_intrinsic(local, ord[0], ord[1], ord[2]);
    for (int k = 0; k < 3; ++k) out->values(f, col++) = e(k) * kDegPerRad;
  }
}

}  // namespace

/// Far end of a leaf segment, m, in the standing pose: toes point forward (+x), hands hang
/// down (-z), head and the gait trunk end at their tops (+z).
Vector3d segment_end_W(const models::Segment& s) {
  const std::string kind = s.name.substr(0, s.name.find('_'));
  Vector3d dir = Vector3d::UnitZ();
  if (kind == "toes") dir = Vector3d::UnitX();
  if (kind == "hand") dir = -Vector3d::UnitZ();
  return s.origin_W + s.length_m * dir;
}

BvhMotion character_bvh(const models::Character& c, const mjModel& model,
                        const Eigen::MatrixXd& qpos, double frame_time_s, const BvhUnits& units) {
  if (qpos.cols() != model.nq) {
    throw InvalidArgument("character BVH: qpos has " + std::to_string(qpos.cols()) +
                          " columns, the model nq = " + std::to_string(model.nq));
  }
  if (qpos.rows() < 1) throw InvalidArgument("character BVH: no frames");
  if (!(frame_time_s > 0)) {
    throw InvalidArgument("character BVH: frame time must be > 0 s, got " +
                          std::to_string(frame_time_s));
  }
  if (!(units.metres_per_unit > 0)) {
    throw InvalidArgument("character BVH: metres_per_unit must be > 0, got " +
                          std::to_string(units.metres_per_unit));
  }
  std::vector<int> body(c.segments.size());
  const models::Rig rig(model);
  for (size_t i = 0; i < c.segments.size(); ++i) {
    body[i] = rig.body(c.segments[i].name);
    if (body[i] < 0) {
      throw InvalidArgument("character BVH: the model has no body '" + c.segments[i].name +
                            "' (a model of another character)");
    }
  }
  const BvhAxes ax = bvh_axes(units.up);
  BvhMotion out;
  out.frame_time_s = frame_time_s;
  int channels = 0;
  const std::vector<int> order = add_hierarchy(c, ax, units.metres_per_unit, &out, &channels);

  // An unsolved (NaN) frame repeats the last solved one, or the standing pose.
  out.values = Eigen::MatrixXd::Zero(qpos.rows(), channels);
  sim::Data data(model);
  std::vector<mjtNum> q(model.qpos0, model.qpos0 + model.nq);
  for (Eigen::Index f = 0; f < qpos.rows(); ++f) {
    if (qpos.row(f).allFinite()) {
      for (int k = 0; k < model.nq; ++k) q[static_cast<size_t>(k)] = qpos(f, k);
    }
    mju_copy(data->qpos, q.data(), model.nq);
    mj_kinematics(&model, data.get());
    write_frame(ax, body, order, units.metres_per_unit, *data, f, &out);
  }
  return out;
}

}  // namespace biodyn::mocap_io
