#include "biodyn/mocap_io/scaling.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "biodyn/mocap_io/marker_ik.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"

namespace biodyn::mocap_io {
namespace {

std::vector<double> weights_for(const models::MarkerSet& set, const MarkerData& trial) {
  std::vector<double> w;
  for (const std::string& label : trial.labels) w.push_back(set.weight(label));
  return w;
}

/// The scale factors of `set`'s measurements on character `c` against `trial`; a measurement
/// the trial cannot make is described in *unmeasured instead. Throws sim::InvalidArgument for a
/// marker the set measures but does not put on the character.
std::vector<ScaleFactor> measure(const models::Character& c, const models::MarkerSet& set,
                                 const MarkerData& trial, std::vector<std::string>* unmeasured) {
  unmeasured->clear();
  const std::map<std::string, Eigen::Vector3d> model_pos = standing_marker_positions(c);
  std::vector<ScaleFactor> out;
  for (size_t k = 0; k < set.scaling.size(); ++k) {
    const models::ScaleMeasurement& meas = set.scaling[k];
    ScaleFactor sf;
    sf.segments = meas.segments;
    sf.measurement = static_cast<int>(k);
    std::string segments;
    for (const std::string& seg : meas.segments) segments += (segments.empty() ? "" : ", ") + seg;
    const std::string what = "scaling[" + std::to_string(k) + "] (" + meas.pairs[0].first + "-" +
                             meas.pairs[0].second + ", " + segments + ")";
    std::vector<std::pair<int, int>> columns;
    double model_sum = 0.0;
    std::string missing;
    for (const auto& [a, b] : meas.pairs) {
      for (const std::string& name : {a, b}) {
        if (model_pos.count(name) == 0) {
          throw sim::InvalidArgument("scaling[" + std::to_string(k) + "]: marker " + name +
                                     " is not on the " + models::to_string(c.spec.detail) +
                                     " character");
        }
        if (trial.find(name) < 0 && missing.empty()) missing = name;
      }
      model_sum += (model_pos.at(a) - model_pos.at(b)).norm();
      columns.emplace_back(trial.find(a), trial.find(b));
    }
    if (!missing.empty()) {
      unmeasured->push_back(what + ": the trial has no marker labelled " + missing +
                            "; kept at the height-scaled size");
      continue;
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
      unmeasured->push_back(what + ": no frame of the trial shows all its markers; kept at the " +
                            "height-scaled size");
      continue;
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

/// m: the stature `height_m` scaled by the mean factor of the length measurements (stature
/// follows the segment lengths; widths are not statures), within the spec's bounds.
double estimated_height(double height_m, const models::MarkerSet& set,
                        const std::vector<ScaleFactor>& factors) {
  double mean = 0.0;
  int lengths = 0;
  for (const ScaleFactor& f : factors) {
    if (set.scaling[static_cast<size_t>(f.measurement)].dimension == "width") continue;
    mean += f.factor;
    ++lengths;
  }
  mean = lengths > 0 ? mean / lengths : 1.0;
  return std::clamp(height_m * mean, models::CharacterSpec::kMinHeight,
                    models::CharacterSpec::kMaxHeight);
}

/// The factors as overrides of `spec`: each measured segment's length (on `plain`) scaled, and
/// the pelvis's width (its hip joint separation). Throws sim::InvalidArgument for a segment the
/// character lacks or a width on another segment than the pelvis.
void apply_factors(const models::Character& plain, const models::MarkerSet& set,
                   const std::vector<ScaleFactor>& factors, models::CharacterSpec* spec) {
  for (const ScaleFactor& f : factors) {
    const size_t k = static_cast<size_t>(f.measurement);
    for (const std::string& seg : f.segments) {
      const models::Segment* s = plain.find(seg);
      if (s == nullptr) {
        throw sim::InvalidArgument("scaling: segment '" + seg + "' is not in the " +
                                   std::string(models::to_string(spec->detail)) + " character");
      }
      if (set.scaling[k].dimension == "width") {
        if (seg != "pelvis") {
          throw sim::InvalidArgument("scaling[" + std::to_string(k) +
                                     "]: only the pelvis has a "
                                     "width (hip joint separation), got '" +
                                     seg + "'");
        }
        const double hip_separation =
            (plain.find("thigh_l")->origin_W - plain.find("thigh_r")->origin_W).norm();
        spec->overrides[seg].width_m = f.factor * hip_separation;
      } else {
        spec->overrides[seg].length_m = f.factor * s->length_m;
      }
    }
  }
}

/// Up to `wanted` frames spread evenly among those the IK solved. Throws sim::InvalidArgument
/// if it solved none.
std::vector<int> placement_frames(const MarkerIkResult& ik, int frames, int wanted) {
  std::vector<int> solved;
  for (int f = 0; f < frames; ++f) {
    if (ik.frames[static_cast<size_t>(f)].solved) solved.push_back(f);
  }
  if (solved.empty()) {
    throw sim::InvalidArgument("static trial: no frame has enough visible markers for IK");
  }
  std::vector<int> picked;
  const int n = std::min<int>(wanted, static_cast<int>(solved.size()));
  for (int i = 0; i < n; ++i) {
    picked.push_back(solved[static_cast<size_t>(i * static_cast<int>(solved.size()) / n)]);
  }
  return picked;
}

/// The final fit's marker error over the `picked` frames into result's static_rms_m and
/// static_max_m.
void report_fit(const MarkerIkResult& ik, const std::vector<int>& picked, ScaleResult* result) {
  double sum_sq = 0.0;
  int count = 0;
  for (int f : picked) {
    const MarkerIkFrame& fr = ik.frames[static_cast<size_t>(f)];
    sum_sq += fr.rms_error_m * fr.rms_error_m * fr.markers_used;
    count += fr.markers_used;
    result->static_max_m = std::max(result->static_max_m, fr.max_error_m);
  }
  result->static_rms_m = std::sqrt(sum_sq / std::max(count, 1));
}

/// Each marker of `scaled` that is not fixed, measured in its body's frame over the `picked`
/// frames of the IK's fit: the sum of its positions (m) and how many were summed.
struct BodyFrameSums {
  std::map<std::string, Eigen::Vector3d> sum_B;
  std::map<std::string, int> count_B;
};

BodyFrameSums measure_in_bodies(const mjModel& m, const models::Character& scaled,
                                const models::MarkerSet& set, const MarkerData& static_trial,
                                const MarkerIkResult& ik, const std::vector<int>& picked) {
  BodyFrameSums sums;
  const models::Rig rig(m);
  sim::Data d(m);
  for (int f : picked) {
    for (int k = 0; k < m.nq; ++k) d->qpos[k] = ik.qpos(f, k);
    mj_kinematics(&m, d.get());
    for (const models::Marker& mk : scaled.markers) {
      if (set.fixed.count(mk.name)) continue;
      const int col = static_trial.find(mk.name);
      if (col < 0 || !static_trial.visible(f, col)) continue;
      const int body = rig.body(mk.segment);
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> r_WB(d->xmat + 9 * body);
      const Eigen::Vector3d p_W(d->xpos + 3 * body);
      const auto [it, fresh] = sums.sum_B.try_emplace(mk.name, Eigen::Vector3d::Zero());
      it->second += r_WB.transpose() * (static_trial.position(f, col) - p_W);
      sums.count_B[mk.name] += 1;
    }
  }
  return sums;
}

/// Marker placement: fit the static trial, move the markers that are not fixed to their mean
/// measured position in their body's frame, refit; the last fit is reported.
void place_markers(const models::MarkerSet& set, const MarkerData& static_trial,
                   const ScaleOptions& options, models::CharacterSpec* spec, ScaleResult* result) {
  const std::vector<double> weights = weights_for(set, static_trial);
  const int frames = static_trial.frame_count();
  for (int round = 0; round <= options.placement_iterations; ++round) {
    const models::Character scaled = models::generate_character(*spec);
    const sim::Model model = compile(scaled);
    const mjModel& m = *model;
    // The first fit is on generic placements, centimetres off by design: refuse no frame.
    MarkerIkOptions ik_options;
    ik_options.max_frame_rms_m = std::numeric_limits<double>::infinity();
    const MarkerIkResult ik = solve_marker_ik(m, static_trial, weights, ik_options);
    const std::vector<int> picked = placement_frames(ik, frames, options.placement_frames);
    if (round == options.placement_iterations) {  // the final fit: report it
      report_fit(ik, picked, result);
      break;
    }
    const BodyFrameSums sums = measure_in_bodies(m, scaled, set, static_trial, ik, picked);
    for (models::MarkerPlacement& p : spec->markers) {
      const auto it = sums.sum_B.find(p.name);
      if (it == sums.sum_B.end()) continue;
      p.position_B = it->second / sums.count_B.at(p.name);
    }
    if (round == 0) {
      for (const auto& [name, s] : sums.sum_B) result->placed.push_back(name);
    }
  }
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
  std::vector<ScaleFactor> factors = measure(plain, set, static_trial, &result.unmeasured);
  if (!height_given && options.estimate_height && !factors.empty()) {
    spec.height_m = estimated_height(spec.height_m, set, factors);
    plain = models::generate_character(spec);
    factors = measure(plain, set, static_trial, &result.unmeasured);
  }
  apply_factors(plain, set, factors, &spec);
  result.factors = factors;
  place_markers(set, static_trial, options, &spec, &result);
  result.spec = spec;
  return result;
}

}  // namespace biodyn::mocap_io
