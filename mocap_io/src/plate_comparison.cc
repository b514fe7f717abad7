// An estimate of the ground forces against measured force plates (inverse_dynamics.h).
#include <cmath>
#include <limits>

#include "biodyn/mocap_io/inverse_dynamics.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "plate_assignment.h"

namespace biodyn::mocap_io {
namespace {

/// m: a sole point this far outside a plate's edge is still seen by it.
constexpr double kWholeFootMargin_m = 0.01;
/// m: a sole point this high above its floor (the estimate's foot-flat calibration) may be
/// touching it: the plate must see it. A fixed height, so the frames compared do not depend
/// on the estimate's own thresholds.
constexpr double kTouchingHeight_m = 0.05;
/// Body weights: a foot the estimate loads less than this is off the floor (single support).
constexpr double kUnloadedFoot_bw = 0.02;

/// Whether every sole point of `side` that may touch the floor at frame f is over `plate`.
bool plate_sees_whole_foot(const mjData& d, const GroundForceEstimate& e, int f, int side,
                           const ForcePlate& plate) {
  for (size_t c = 0; c < e.points.size(); ++c) {
    const SoleContactPoint& p = e.points[c];
    if (p.side != side || e.height_m(f, static_cast<int>(c)) > kTouchingHeight_m) continue;
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> r(d.xmat + 9 * p.body);
    const Eigen::Vector3d world =
        Eigen::Vector3d(d.xpos[3 * p.body], d.xpos[3 * p.body + 1], d.xpos[3 * p.body + 2]) +
        r * p.pos_B;
    if (!plate_internal::over_plate(plate, world.head<2>(), kWholeFootMargin_m)) return false;
  }
  return true;
}

}  // namespace

PlateComparison compare_with_plates(const mjModel& model, const InverseDynamicsResult& estimated,
                                    const std::vector<ForcePlate>& plates, double plate_rate_hz) {
  const GroundForceEstimate& e = estimated.ground_estimate;
  const int frames = static_cast<int>(estimated.times_s.size());
  if (e.activation.rows() != frames || frames == 0) {
    throw sim::InvalidArgument("plate comparison: the inverse dynamics has no ground estimate");
  }
  const models::Rig rig(model);
  const plate_internal::PlateFeet feet(model,
                                       {rig.leg(models::kLeft).foot, rig.leg(models::kRight).foot});
  sim::Data data(model);
  mjData* d = data.get();
  double mass = 0;
  for (int b = 1; b < model.nbody; ++b) mass += model.body_mass[b];
  PlateComparison out;
  out.body_weight_N = mass * std::sqrt(mju_dot(model.opt.gravity, model.opt.gravity, 3));
  double sum_v = 0, sum_fa = 0, sum_lat = 0, plate_single = 0, estimate_single = 0;
  for (int f = 0; f < frames; ++f) {
    for (int k = 0; k < model.nq; ++k) d->qpos[k] = estimated.qpos(f, k);
    mj_kinematics(&model, d);
    for (const ForcePlate& plate : plates) {
      const plate_internal::PlateSample s = plate_internal::plate_sample(
          plate, plate_rate_hz, estimated.times_s[static_cast<size_t>(f)]);
      if (std::abs(s.force_N.z()) < plate_internal::kMinPlateLoad_N || !s.cop_m.allFinite())
        continue;
      const int side = feet.foot_for(*d, plate, s.cop_m);
      if (side < 0 || !plate_sees_whole_foot(*d, e, f, side, plate)) continue;
      const Eigen::Vector3d est = e.force_N[static_cast<size_t>(side)].row(f).transpose();
      const Eigen::Vector3d err = est - s.force_N;
      // The pelvis's heading: its x axis, horizontal.
      const int pelvis = rig.pelvis() >= 0 ? rig.pelvis() : 1;
      Eigen::Vector2d ahead(d->xmat[9 * pelvis], d->xmat[9 * pelvis + 3]);
      ahead = ahead.norm() > 1e-9 ? Eigen::Vector2d(ahead.normalized()) : Eigen::Vector2d(1, 0);
      const double fa = ahead.dot(err.head<2>());
      const double lat = ahead.x() * err.y() - ahead.y() * err.x();
      sum_v += err.z() * err.z();
      sum_fa += fa * fa;
      sum_lat += lat * lat;
      out.vertical_peak_error_N = std::max(out.vertical_peak_error_N, std::abs(err.z()));
      if (e.force_N[static_cast<size_t>(1 - side)](f, 2) < kUnloadedFoot_bw * out.body_weight_N) {
        plate_single += s.force_N.z();
        estimate_single += est.z();
        ++out.single_support_frames;
      }
      out.times_s.push_back(estimated.times_s[static_cast<size_t>(f)]);
      out.sides.push_back(side);
      out.estimated_N.push_back(est);
      out.measured_N.push_back(s.force_N);
    }
  }
  out.frames = static_cast<int>(out.times_s.size());
  if (out.frames > 0) {
    out.vertical_rms_N = std::sqrt(sum_v / out.frames);
    out.fore_aft_rms_N = std::sqrt(sum_fa / out.frames);
    out.lateral_rms_N = std::sqrt(sum_lat / out.frames);
  }
  out.single_support_ratio = estimate_single > 0 ? plate_single / estimate_single
                                                 : std::numeric_limits<double>::quiet_NaN();
  return out;
}

}  // namespace biodyn::mocap_io
