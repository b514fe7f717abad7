// The character's own BVH (retarget.h: character_bvh): one joint per segment, rotations from
// MuJoCo's kinematics of the qpos, decomposed into Euler angles in gimbal-safe orders.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>

#include "biodyn/mocap_io/retarget.h"
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
  for (size_t i = 0; i < c.segments.size(); ++i) {
    body[i] = mj_name2id(&model, mjOBJ_BODY, c.segments[i].name.c_str());
    if (body[i] < 0) {
      throw InvalidArgument("character BVH: the model has no body '" + c.segments[i].name +
                            "' (a model of another character)");
    }
  }
  // File axes of the world's forward (x), lateral (y) and up (z) directions.
  const Matrix3d a = file_to_world(units.up);
  const Matrix3d a_t = a.transpose();
  int axis_of[3];
  for (int w = 0; w < 3; ++w) {
    Eigen::Index axis = 0;
    a_t.col(w).cwiseAbs().maxCoeff(&axis);
    axis_of[w] = static_cast<int>(axis);
  }
  const int fwd = axis_of[0], lat = axis_of[1], up = axis_of[2];
  const int root_order[3] = {up, lat, fwd};  // heading first, pitch in the middle
  const int joint_order[3] = {fwd, up, lat};  // twist about the vertical in the middle

  BvhMotion out;
  out.frame_time_s = frame_time_s;
  // Depth-first order over the segments (parents before children in c.segments).
  std::vector<int> order;  // segment index per BVH joint, -1 for an end site
  int channels = 0;
  const std::function<void(size_t, int)> visit = [&](size_t s, int parent_joint) {
    const models::Segment& seg = c.segments[s];
    BvhJoint j;
    j.name = seg.name;
    j.parent = parent_joint;
    const Vector3d rel = parent_joint < 0 ? Vector3d::Zero()
                                          : Vector3d(seg.origin_W - c.find(seg.parent)->origin_W);
    j.offset = a_t * rel / units.metres_per_unit;
    if (parent_joint < 0) {
      j.channels = {BvhChannel::kXposition, BvhChannel::kYposition, BvhChannel::kZposition};
      for (int ax : root_order) j.channels.push_back(rotation_channel(ax));
    } else {
      for (int ax : joint_order) j.channels.push_back(rotation_channel(ax));
    }
    j.first_channel = channels;
    channels += static_cast<int>(j.channels.size());
    const int me = static_cast<int>(out.joints.size());
    out.joints.push_back(j);
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
      e.offset = a_t * (segment_end_W(seg) - seg.origin_W) / units.metres_per_unit;
      e.first_channel = channels;
      out.joints.push_back(e);
      order.push_back(-1);
    }
  };
  visit(0, -1);

  out.values = Eigen::MatrixXd::Zero(qpos.rows(), channels);
  sim::Data data(model);
  std::vector<mjtNum> q(model.qpos0, model.qpos0 + model.nq);
  for (Eigen::Index f = 0; f < qpos.rows(); ++f) {
    if (qpos.row(f).allFinite()) {
      for (int k = 0; k < model.nq; ++k) q[static_cast<size_t>(k)] = qpos(f, k);
    }
    mju_copy(data->qpos, q.data(), model.nq);
    mj_kinematics(&model, data.get());
    for (size_t bj = 0; bj < out.joints.size(); ++bj) {
      const int s = order[bj];
      if (s < 0) continue;
      const BvhJoint& j = out.joints[bj];
      const int b = body[static_cast<size_t>(s)];
      const Matrix3d r_wb = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(
          data->xmat + 9 * b);
      Matrix3d local;
      int col = j.first_channel;
      if (j.parent < 0) {
        const Vector3d p = a_t * Vector3d(data->xpos + 3 * b) / units.metres_per_unit;
        for (int k = 0; k < 3; ++k) out.values(f, col++) = p(k);
        local = a_t * r_wb * a;
      } else {
        const int pb = body[static_cast<size_t>(order[static_cast<size_t>(j.parent)])];
        const Matrix3d r_wp = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(
            data->xmat + 9 * pb);
        local = a_t * r_wp.transpose() * r_wb * a;
      }
      const int* ord = j.parent < 0 ? root_order : joint_order;
      const Vector3d e = euler_intrinsic(local, ord[0], ord[1], ord[2]);
      for (int k = 0; k < 3; ++k) out.values(f, col++) = e(k) * kDegPerRad;
    }
  }
  return out;
}

}  // namespace biodyn::mocap_io
