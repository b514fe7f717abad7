#include "biodyn/mocap_io/scaling.h"

#include <algorithm>
#include <cmath>

#include "biodyn/mocap_io/marker_ik.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"

namespace biodyn::mocap_io {
namespace {

std::vector<double> weights_for(const models::MarkerSet& set, const MarkerData& trial) {
  std::vector<double> w;
  for (const std::string& label : trial.labels) w.push_back(set.weight(label));
  return w;
}

/// The scale factors of `set`'s measurements on character `c` against `trial`.
std::vector<ScaleFactor> measure(const models::Character& c, const models::MarkerSet& set,
                                 const MarkerData& trial) {
  const std::map<std::string, Eigen::Vector3d> model_pos = standing_marker_positions(c);
  std::vector<ScaleFactor> out;
  for (size_t k = 0; k < set.scaling.size(); ++k) {
    const models::ScaleMeasurement& meas = set.scaling[k];
    ScaleFactor sf;
    sf.segments = meas.segments;
    std::vector<std::pair<int, int>> columns;
    double model_sum = 0.0;
    for (const auto& [a, b] : meas.pairs) {
      for (const std::string& name : {a, b}) {
        if (model_pos.count(name) == 0) {
          throw sim::InvalidArgument("scaling[" + std::to_string(k) + "]: marker " + name +
                                     " is not on the " + models::to_string(c.spec.detail) +
                                     " character");
        }
        if (trial.find(name) < 0) {
          throw sim::InvalidArgument("scaling[" + std::to_string(k) + "]: the static trial has no "
                                     "marker labelled " + name);
        }
      }
      model_sum += (model_pos.at(a) - model_pos.at(b)).norm();
      columns.emplace_back(trial.find(a), trial.find(b));
    }
    sf.model_m = model_sum / static_cast<double>(meas.pairs.size());
    double measured_sum = 0.0;
    for (int f = 0; f < trial.frame_count(); ++f) {
      double frame_sum = 0.0;
      bool all = true;
      for (const auto& [ia, ib] : columns) {
        if (!trial.visible(f, ia) || !trial.visible(f, ib)) {
          all = false;
          break;
        }
        frame_sum += (trial.position(f, ia) - trial.position(f, ib)).norm();
      }
      if (!all) continue;
      measured_sum += frame_sum / static_cast<double>(columns.size());
      ++sf.frames;
    }
    if (sf.frames == 0) {
      throw sim::InvalidArgument("scaling[" + std::to_string(k) + "] (" + meas.pairs[0].first +
                                 "-" + meas.pairs[0].second +
                                 "): no frame of the static trial shows all its markers");
    }
    sf.measured_m = measured_sum / sf.frames;
    sf.factor = sf.measured_m / sf.model_m;
    out.push_back(sf);
  }
  return out;
}

sim::Model compile(const models::Character& c) {
  return sim::Model::from_string(models::to_mjcf(c), "scaled character");
}

}  // namespace

std::map<std::string, Eigen::Vector3d> standing_marker_positions(const models::Character& c) {
  std::map<std::string, Eigen::Vector3d> out;
  for (const models::Marker& m : c.markers) {
    out[m.name] = c.find(m.segment)->origin_W + m.position_B;
  }
  return out;
}

ScaleResult scale_from_static(const models::CharacterSpec& base, bool height_given,
                              const models::MarkerSet& set, const MarkerData& static_trial,
                              const ScaleOptions& options) {
  ScaleResult result;
  models::CharacterSpec spec = base;
  spec.markers = set.markers;
  spec.overrides.clear();
  models::Character plain = models::generate_character(spec);
  std::vector<ScaleFactor> factors = measure(plain, set, static_trial);
  if (!height_given && options.estimate_height && !factors.empty()) {
    // Stature follows the segment lengths (widths are not statures).
    double mean = 0.0;
    int lengths = 0;
    for (size_t k = 0; k < factors.size(); ++k) {
      if (set.scaling[k].dimension == "width") continue;
      mean += factors[k].factor;
      ++lengths;
    }
    mean = lengths > 0 ? mean / lengths : 1.0;
    spec.height_m = std::clamp(spec.height_m * mean, models::CharacterSpec::kMinHeight,
                               models::CharacterSpec::kMaxHeight);
    plain = models::generate_character(spec);
    factors = measure(plain, set, static_trial);
  }
  for (size_t k = 0; k < factors.size(); ++k) {
    const ScaleFactor& f = factors[k];
    for (const std::string& seg : f.segments) {
      const models::Segment* s = plain.find(seg);
      if (s == nullptr) {
        throw sim::InvalidArgument("scaling: segment '" + seg + "' is not in the " +
                                   std::string(models::to_string(spec.detail)) + " character");
      }
      if (set.scaling[k].dimension == "width") {
        if (seg != "pelvis") {
          throw sim::InvalidArgument("scaling[" + std::to_string(k) + "]: only the pelvis has a "
                                     "width (hip joint separation), got '" + seg + "'");
        }
        const double hip_separation =
            (plain.find("thigh_l")->origin_W - plain.find("thigh_r")->origin_W).norm();
        spec.overrides[seg].width_m = f.factor * hip_separation;
      } else {
        spec.overrides[seg].length_m = f.factor * s->length_m;
      }
    }
  }
  result.factors = factors;

  // Marker placement: fit the static trial, move the markers that are not fixed to their mean
  // measured position in their body's frame, refit.
  const std::vector<double> weights = weights_for(set, static_trial);
  const int frames = static_trial.frame_count();
  for (int round = 0; round <= options.placement_iterations; ++round) {
    const models::Character scaled = models::generate_character(spec);
    const sim::Model model = compile(scaled);
    const mjModel& m = *model;
    const MarkerIkResult ik = solve_marker_ik(m, static_trial, weights);
    std::vector<int> solved;
    for (int f = 0; f < frames; ++f) {
      if (ik.frames[static_cast<size_t>(f)].solved) solved.push_back(f);
    }
    if (solved.empty()) {
      throw sim::InvalidArgument("static trial: no frame has enough visible markers for IK");
    }
    // Evenly spread placement frames among the solved ones.
    std::vector<int> picked;
    const int n = std::min<int>(options.placement_frames, static_cast<int>(solved.size()));
    for (int i = 0; i < n; ++i) {
      picked.push_back(solved[static_cast<size_t>(i * static_cast<int>(solved.size()) / n)]);
    }
    if (round == options.placement_iterations) {  // the final fit: report it
      double sum_sq = 0.0;
      int count = 0;
      for (int f : picked) {
        const MarkerIkFrame& fr = ik.frames[static_cast<size_t>(f)];
        sum_sq += fr.rms_error_m * fr.rms_error_m * fr.markers_used;
        count += fr.markers_used;
        result.static_max_m = std::max(result.static_max_m, fr.max_error_m);
      }
      result.static_rms_m = std::sqrt(sum_sq / std::max(count, 1));
      break;
    }
    sim::Data d(m);
    std::map<std::string, Eigen::Vector3d> sum_B;
    std::map<std::string, int> count_B;
    for (int f : picked) {
      for (int k = 0; k < m.nq; ++k) d->qpos[k] = ik.qpos(f, k);
      mj_kinematics(&m, d.get());
      for (const models::Marker& mk : scaled.markers) {
        if (set.fixed.count(mk.name)) continue;
        const int col = static_trial.find(mk.name);
        if (col < 0 || !static_trial.visible(f, col)) continue;
        const int body = mj_name2id(&m, mjOBJ_BODY, mk.segment.c_str());
        const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> r_WB(d->xmat + 9 * body);
        const Eigen::Vector3d p_W(d->xpos + 3 * body);
        const auto [it, fresh] = sum_B.try_emplace(mk.name, Eigen::Vector3d::Zero());
        it->second += r_WB.transpose() * (static_trial.position(f, col) - p_W);
        count_B[mk.name] += 1;
      }
    }
    for (models::MarkerPlacement& p : spec.markers) {
      const auto it = sum_B.find(p.name);
      if (it == sum_B.end()) continue;
      p.position_B = it->second / count_B.at(p.name);
    }
    if (round == 0) {
      for (const auto& [name, s] : sum_B) result.placed.push_back(name);
    }
  }
  result.spec = spec;
  return result;
}

}  // namespace biodyn::mocap_io
