// Retargeting (retarget_internal.h): the IK's sites on the character and the IK pass. In swing
// a foot's roll is the IK's own from the frame before (targets follow it: the roll is free),
// scaled down to level near its contacts, and its sole weighs as a keypoint. A planted point
// the IK cannot hold is released and the frame solved again: the character lifts its heel (or
// toes) early where the capture's pose is out of its joints' reach, instead of sliding.
#include <algorithm>
#include <cmath>
#include <limits>

#include "retarget_internal.h"

namespace biodyn::mocap_io::retarget_internal {
namespace {

/// A roll-weight below this counts as zero when the swing roll is rescaled frame to frame.
constexpr double kMinRollWeight = 1e-3;
/// IK solves per frame at most: the first, then one per released contact or new floor guard.
constexpr int kMaxSolvesPerFrame = 40;
/// An active floor guard weighs this many times a planted point. Heavier guards fight the pins
/// (measured on the CMU clip: 3x and 10x raise the worst stance slide from 2.1 to 2.7 cm);
/// what they lack is made up by aiming them higher instead (see hold_up_guards).
constexpr double kGuardWeightFactor = 1.0;
/// m: a floor guard this far below its clearance is held up (and the frame solved again).
constexpr double kGuardTolerance_m = 0.001;
/// m: a foot's last planted point held off the floor by more than this is let go (the foot
/// has lifted: a kneel on a foot the character cannot roll onto its edge); a smaller miss is
/// kept pinned (and reported).
constexpr double kLiftOff_m = 0.02;
/// A planted point's miss counts as upward (off the floor) or downward (into it) when its
/// vertical part is over half of it (30 degrees off the vertical at most... 60 from level).
constexpr double kLiftedCos = 0.5;

/// The marker part naming the body that carries `segment` (the gait trunk is carried by the
/// lumbar part's body).
std::string part_of(const std::string& segment) { return segment == "trunk" ? "lumbar" : segment; }

/// Adds `m` to `spec`'s markers and its label, weighing `weight`, to `sites`.
void add_site(const models::MarkerPlacement& m, double weight, IkSites* sites,
              models::CharacterSpec* spec) {
  spec->markers.push_back(m);
  sites->labels.push_back(m.name);
  sites->weights.push_back(weight);
}

/// The keypoints' sites (but the toes': the sole points stand in for them), weighing their map
/// weight.
void add_keypoint_sites(const RetargetInput& in, IkSites* sites, models::CharacterSpec* spec) {
  const int nk = static_cast<int>(in.kps.size());
  for (int i = 0; i < nk; ++i) {
    const Keypoint& k = in.kps[at(i)];
    if (k.name.rfind("toes_", 0) == 0) continue;
    models::MarkerPlacement m;
    m.name = "kp_" + k.name;
    m.part = part_of(k.site_segment);
    m.position_B = k.o_W - in.plain.find(k.site_segment)->origin_W;
    m.description = "retargeting keypoint " + k.name;
    add_site(m, k.map.weight, sites, spec);
    sites->label_kp.push_back(i);
  }
  sites->n_kp = static_cast<int>(sites->labels.size());
}

/// The sole points' sites, weighing `contact_weight`.
void add_sole_sites(const std::array<FootTrack, 2>& feet, double contact_weight, IkSites* sites,
                    models::CharacterSpec* spec) {
  for (int s = 0; s < 2; ++s) {
    for (int p = 0; p < kSoles; ++p) {
      models::MarkerPlacement m;
      m.name = std::string("sole_") + Sole::kNames[p] + "_" + kSides[s];
      m.part = std::string(Sole::on_toes(p) ? "toes_" : "foot_") + kSides[s];
      m.position_B = feet[at(s)].sole.point_B[at(p)];
      m.description = "retargeting sole point";
      add_site(m, contact_weight, sites, spec);
    }
  }
}

/// Floor guards: the sole points and the other corners of the foot and toes boxes (clearance
/// 0), and the ends of the shank and thigh capsules (clearance: the radius). Untargeted
/// (weight 0) until a solve puts one below the floor.
void add_floor_guards(const models::Character& plain, IkSites* sites, models::CharacterSpec* spec) {
  for (int i = 0; i < 2 * kSoles; ++i) sites->guards.push_back({sites->n_kp + i, 0.0});
  for (int s = 0; s < 2; ++s) {
    const auto add_guard = [&](const std::string& segment, const std::string& name,
                               const Vector3d& p_B, double clearance) {
      models::MarkerPlacement m;
      m.name = "guard_" + name + "_" + kSides[s];
      m.part = segment;
      m.position_B = p_B;
      m.description = "retargeting floor guard";
      sites->guards.push_back({static_cast<int>(sites->labels.size()), clearance});
      add_site(m, 0.0, sites, spec);
    };
    const std::string sd = kSides[s];
    for (const char* seg : {"foot_", "toes_"}) {
      // The box corners the sole points leave out: the front bottom ones and the top ones (a
      // foot rolled onto its edge, as in a kneel, can put a top corner lowest).
      const models::Geom& box = plain.find(seg + sd)->geoms.front();
      for (double up : {-1.0, 1.0}) {
        for (double front : {-1.0, 1.0}) {
          if (up < 0 && front < 0) continue;  // the back bottom corners are sole points
          for (double left : {-1.0, 1.0}) {
            const std::string name = std::string(seg) + (front > 0 ? "front_" : "back_") +
                                     (up > 0 ? "top_" : "bottom_") + (left > 0 ? "left" : "right");
            add_guard(seg + sd, name,
                      box.center_B + box.half_extents.cwiseProduct(Vector3d(front, left, up)), 0.0);
          }
        }
      }
    }
    for (const char* seg : {"shank_", "thigh_"}) {
      const models::Geom& capsule = plain.find(seg + sd)->geoms.front();
      add_guard(seg + sd, std::string(seg) + "top", capsule.from_B, capsule.radius);
      add_guard(seg + sd, std::string(seg) + "bottom", capsule.to_B, capsule.radius);
    }
  }
}

/// Writes frame f's targets of both feet (their sole points and ankle keypoints), the feet
/// rolled by `roll` (rad), into `positions` (frames x 3 labels).
void write_feet(const std::array<FootTrack, 2>& feet, const IkSites& sites, int f,
                const std::array<double, 2>& roll, Eigen::MatrixXd* positions) {
  for (int s = 0; s < 2; ++s) {
    SolePoints sole;
    Vector3d ankle;
    feet[at(s)].compose(f, roll[at(s)], &sole, &ankle);
    for (int p = 0; p < kSoles; ++p) {
      positions->row(f).segment<3>(3 * (sites.n_kp + s * kSoles + p)) = sole[at(p)].transpose();
    }
    for (int l = 0; l < sites.n_kp; ++l) {
      if (sites.label_kp[at(l)] == sites.ankle_kp[at(s)]) {
        positions->row(f).segment<3>(3 * l) = ankle.transpose();
      }
    }
  }
}

/// A planted sole point the IK missed: the one to release.
struct PlantedMiss {
  double error_m = 0.0;  ///< m, how far the IK left the planted point it decided on from its pin
  int side = -1;
  int point = -1;  ///< the point to release (a planted point of `side`)
};

/// The IK pass over every frame (solve_ik).
class IkPass {
 public:
  IkPass(const sim::Model& model, const std::vector<int>& site_of_label,
         const RetargetOptions& options, int blend, IkSites* sites, std::array<FootTrack, 2>* feet,
         Eigen::MatrixXd* targets, sim::Data* data, RetargetStats* stats)
      : model_(model),
        site_of_label_(site_of_label),
        options_(options),
        blend_(blend),
        sites_(*sites),
        feet_(*feet),
        targets_(*targets),
        data_(*data),
        stats_(*stats),
        ik_(*model, sites->labels, sites->weights, ik_options(options)),
        q_(model->qpos0, model->qpos0 + model->nq),
        q_start_(q_),
        qpos_(Eigen::MatrixXd::Constant(targets->rows(), model->nq,
                                        std::numeric_limits<double>::quiet_NaN())),
        row_(targets->cols()) {
    for (int s = 0; s < 2; ++s) {
      foot_body_[at(s)] = model.id(mjOBJ_BODY, std::string("foot_") + kSides[s]);
    }
  }

  IkSolution run(const std::function<void(double)>& progress) {
    const int frames = static_cast<int>(targets_.rows());
    for (int f = 0; f < frames; ++f) {
      solve_frame(f);
      if (progress && (f % 64 == 0 || f + 1 == frames)) progress((f + 1.0) / frames);
    }
    return {qpos_, iterations_};
  }

 private:
  static MarkerIkOptions ik_options(const RetargetOptions& options) {
    MarkerIkOptions o = options.ik;
    o.min_visible_fraction = 0.0;  // every frame has its targets; guards are often off
    return o;
  }

  /// Frame f solved until no planted point needs releasing and no guard holding up (at most
  /// kMaxSolvesPerFrame solves); its pose written to qpos_ unless the IK fails.
  void solve_frame(int f) {
    const std::array<double, 2> roll = swing_roll(f);
    q_start_ = q_;
    std::vector<std::pair<int, Vector3d>> active;  // guard label, its target
    for (int attempt = 0;; ++attempt) {
      set_targets(f, roll, active);
      ik_.set_weights(sites_.weights);
      row_ = targets_.row(f).transpose();
      q_ = q_start_;
      const MarkerIkFrame fr = ik_.solve(row_.data(), have_previous_, q_.data());
      if (!fr.solved) {
        ++stats_.unsolved_frames;
        return;
      }
      iterations_ += fr.iterations;
      mju_copy(data_->qpos, q_.data(), model_->nq);
      mj_kinematics(model_.get(), data_.get());
      const PlantedMiss miss = worst_planted_miss(f);
      if (attempt < kMaxSolvesPerFrame - 1 && miss.error_m > options_.release_error_m) {
        release(&feet_[at(miss.side)], miss.point, f, blend_);
        ++stats_.released_contacts;
        continue;
      }
      const bool added = hold_up_guards(&active);
      if (added && attempt < kMaxSolvesPerFrame - 1) continue;
      have_previous_ = true;
      for (int k = 0; k < model_->nq; ++k) qpos_(f, k) = q_[at(k)];
      return;
    }
  }

  /// rad, each foot's roll at frame f: in swing the IK's own at the frame before (relative to
  /// the free foot's), scaled as the roll weight changes; 0 near and in stance, and before the
  /// first solved frame.
  std::array<double, 2> swing_roll(int f) {
    std::array<double, 2> roll{};
    if (!have_previous_ || f == 0) return roll;
    mju_copy(data_->qpos, q_.data(), model_->nq);
    mj_kinematics(model_.get(), data_.get());
    for (int s = 0; s < 2; ++s) {
      const FootTrack& foot = feet_[at(s)];
      const double w = foot.roll_weight[at(f)], w_prev = foot.roll_weight[at(f - 1)];
      if (w <= 0.0) continue;
      const Matrix3d r_act = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(
          data_->xmat + 9 * foot_body_[at(s)]);
      const Matrix3d r_rel = foot.r_free[at(f - 1)].transpose() * r_act;
      const double measured = std::atan2(r_rel(2, 1), r_rel(1, 1));
      roll[at(s)] = measured * (w_prev > kMinRollWeight ? std::min(1.0, w / w_prev) : 1.0);
    }
    return roll;
  }

  /// Frame f's foot targets and site weights: the sole points weigh from swing_weight to
  /// contact_weight by their contact share; guards are off but the `active` ones (label,
  /// target), which weigh as a planted point.
  void set_targets(int f, const std::array<double, 2>& roll,
                   const std::vector<std::pair<int, Vector3d>>& active) {
    write_feet(feet_, sites_, f, roll, &targets_);
    std::vector<double>& weights = sites_.weights;
    for (int s = 0; s < 2; ++s) {
      for (int p = 0; p < kSoles; ++p) {
        weights[at(sites_.n_kp + s * kSoles + p)] =
            options_.swing_weight + feet_[at(s)].contact_share[at(f)][at(p)] *
                                        (options_.contact_weight - options_.swing_weight);
      }
    }
    const int n_labels = static_cast<int>(sites_.labels.size());
    for (int l = sites_.n_kp + 2 * kSoles; l < n_labels; ++l) {
      weights[at(l)] = 0.0;
      targets_.row(f).segment<3>(3 * l).setConstant(std::numeric_limits<double>::quiet_NaN());
    }
    for (const auto& [l, target] : active) {
      weights[at(l)] = kGuardWeightFactor * options_.contact_weight;
      targets_.row(f).segment<3>(3 * l) = target.transpose();
    }
  }

  /// The planted point of `foot` at frame f furthest from point p on the other part of the
  /// foot (heel against toes), or -1.
  static int far_planted_point(const FootTrack& foot, int f, int p) {
    const auto& planted = foot.planted[at(f)];
    double far = -1.0;
    int release_point = -1;
    for (int o = 0; o < kSoles; ++o) {
      const double d = (foot.sole.point_B[at(o)] - foot.sole.point_B[at(p)]).norm();
      if (o != p && planted[at(o)] && Sole::on_toes(o) != Sole::on_toes(p) && d > far) {
        far = d;
        release_point = o;
      }
    }
    return release_point;
  }

  /// The worst planted point the IK could not hold at frame f (data_ at its solution). Pulled
  /// off the floor, it is released (the heel of an early heel-off, the ball of a toe-off
  /// pivoting on the tip, the outer edge of a foot rolled onto its inner edge; even a foot's
  /// last point: that foot is in the air). Pulled along the floor, it is released only if
  /// another point of its foot stays planted, so a stance never vanishes and a slide is never
  /// hidden. Pushed into the floor, the far end of the foot lets go instead (the heel rises
  /// when the ankle cannot dorsiflex further to keep the ball down).
  PlantedMiss worst_planted_miss(int f) const {
    PlantedMiss worst;
    for (int s = 0; s < 2; ++s) {
      const auto& planted = feet_[at(s)].planted[at(f)];
      const bool others = std::count(planted.begin(), planted.end(), true) >= 2;
      for (int p = 0; p < kSoles; ++p) {
        if (!planted[at(p)]) continue;
        const Vector3d x(data_->site_xpos + 3 * site_of_label_[at(sites_.n_kp + s * kSoles + p)]);
        const Vector3d e = x - feet_[at(s)].plant[at(f)][at(p)];
        const bool lifted = e.z() > kLiftedCos * e.norm() && e.norm() > kLiftOff_m;
        if (e.norm() <= worst.error_m || !(others || lifted)) continue;
        if (e.z() < -kLiftedCos * e.norm()) {  // into the floor: the planted point furthest away
          const int release_point = far_planted_point(feet_[at(s)], f, p);
          if (release_point < 0) continue;
          worst.point = release_point;
        } else {
          worst.point = p;
        }
        worst.error_m = e.norm();
        worst.side = s;
      }
    }
    return worst;
  }

  /// Floor guards below the floor (data_ at the solution) held up where they are; an active
  /// guard still below is aimed higher by what it lacks (the other targets pull it down that
  /// much). Returns whether any was, so the frame is solved again.
  bool hold_up_guards(std::vector<std::pair<int, Vector3d>>* active) const {
    bool added = false;
    for (const Guard& g : sites_.guards) {
      const Vector3d x(data_->site_xpos + 3 * site_of_label_[at(g.label)]);
      const double deficit = g.clearance_m - x.z();
      if (deficit <= kGuardTolerance_m) continue;
      const auto it = std::find_if(active->begin(), active->end(),
                                   [&](const auto& a) { return a.first == g.label; });
      if (it == active->end()) {
        active->push_back({g.label, Vector3d(x.x(), x.y(), g.clearance_m)});
      } else {
        it->second.z() += deficit;
      }
      added = true;
    }
    return added;
  }

  const sim::Model& model_;
  const std::vector<int>& site_of_label_;
  const RetargetOptions& options_;
  const int blend_;
  IkSites& sites_;
  std::array<FootTrack, 2>& feet_;
  Eigen::MatrixXd& targets_;  ///< frames x 3 labels, m
  sim::Data& data_;
  RetargetStats& stats_;
  MarkerIk ik_;
  std::array<int, 2> foot_body_{};
  std::vector<mjtNum> q_, q_start_;  ///< the warm start and the frame's first
  Eigen::MatrixXd qpos_;             ///< frames x nq, NaN until solved
  Eigen::VectorXd row_;              ///< the frame's targets
  bool have_previous_ = false;
  long iterations_ = 0;
};

}  // namespace

IkSites add_ik_sites(const RetargetInput& in, const std::array<FootTrack, 2>& feet,
                     const std::array<FootCalibration, 2>& calibration, double contact_weight,
                     models::CharacterSpec* spec) {
  IkSites sites;
  for (int s = 0; s < 2; ++s) sites.ankle_kp[at(s)] = calibration[at(s)].ankle;
  add_keypoint_sites(in, &sites, spec);
  add_sole_sites(feet, contact_weight, &sites, spec);
  add_floor_guards(in.plain, &sites, spec);
  return sites;
}

MarkerData initial_targets(const std::vector<Eigen::Matrix3Xd>& kp_target,
                           const std::array<FootTrack, 2>& feet, const IkSites& sites, double dt) {
  const int frames = static_cast<int>(kp_target.size());
  const int n_labels = static_cast<int>(sites.labels.size());
  MarkerData targets;
  targets.rate_hz = 1.0 / dt;
  targets.labels = sites.labels;
  targets.positions_m.resize(frames, 3 * n_labels);
  targets.positions_m.setConstant(std::numeric_limits<double>::quiet_NaN());
  for (int f = 0; f < frames; ++f) {
    for (int l = 0; l < sites.n_kp; ++l) {
      targets.positions_m.row(f).segment<3>(3 * l) =
          kp_target[at(f)].col(sites.label_kp[at(l)]).transpose();
    }
    write_feet(feet, sites, f, {0.0, 0.0}, &targets.positions_m);
  }
  return targets;
}

IkSolution solve_ik(const sim::Model& model, const std::vector<int>& site_of_label,
                    const RetargetOptions& options, int blend, IkSites* sites,
                    std::array<FootTrack, 2>* feet, MarkerData* targets, sim::Data* data,
                    RetargetStats* stats, const std::function<void(double)>& progress) {
  IkPass pass(model, site_of_label, options, blend, sites, feet, &targets->positions_m, data,
              stats);
  return pass.run(progress);
}

}  // namespace biodyn::mocap_io::retarget_internal
