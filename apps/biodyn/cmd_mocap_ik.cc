// biodyn mocap ik: marker IK of a C3D or TRC capture on a generated character, scaled by height
// or from a static trial (issue 5; marker_ik.h, scaling.h).
#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/mocap_io/bvh.h"
#include "biodyn/mocap_io/c3d.h"
#include "biodyn/mocap_io/marker_ik.h"
#include "biodyn/mocap_io/marker_labels.h"
#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/mocap_io/scaling.h"
#include "biodyn/mocap_io/trc.h"
#include "biodyn/models/body_file.h"
#include "biodyn/models/marker_set.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/units.h"
#include "cli_common.h"
#include "cmd_mocap.h"

namespace biodyn::apps {
namespace {

using nlohmann::json;

struct IkOptions {
  std::string c3d, trc, markerset, static_trial, output, json_path, lab_up = "z";
  CharacterOptions character;
  int max_iterations = 15;
  double max_frame_rms_m = 0.05;
  bool no_scaling = false;
};

/// The fit a user can trust: mean marker RMS over the solved frames below this (m) is a scaled
/// body on good data (walking5: 7 mm); above it the joint angles are questionable.
constexpr double kTrustedRms_m = 0.02;

/// "50 mm", "12.5 mm": a length in millimetres as a person writes it.
std::string format_mm(double m) {
  std::ostringstream out;
  out << 1000 * m << " mm";
  return out.str();
}

/// Marker trajectories (and what else the file had) from a C3D or TRC file.
struct MarkerFile {
  mocap_io::MarkerData markers;
  std::vector<std::string> inconsistencies;
  std::vector<std::string> notes;  ///< reader_notes: transcoded names, 0 0 0 samples as gaps
};

MarkerFile read_markers(const std::string& path, const std::string& option) {
  switch (format_of(path, option)) {
    case Format::kC3d: {
      mocap_io::C3dFile f = mocap_io::read_c3d(path);
      return {std::move(f.markers), std::move(f.inconsistencies),
              reader_notes(f.transcoded_names, 0)};
    }
    case Format::kTrc: {
      mocap_io::TrcFile f = mocap_io::read_trc(path);
      return {std::move(f.markers), std::move(f.inconsistencies),
              reader_notes(f.transcoded_names, f.zero_samples)};
    }
    default:
      throw sim::InvalidArgument(option + ": expected a .c3d or .trc marker file, got '" + path +
                                 "'");
  }
}

/// Rotates lab-frame markers into biodyn's world (z up) when the lab's vertical is y.
void to_z_up(mocap_io::MarkerData* m, const std::string& lab_up) {
  if (lab_up == "z") return;
  const Eigen::Matrix3d r = mocap_io::file_to_world(mocap_io::UpAxis::kY);
  for (int f = 0; f < m->frame_count(); ++f) {
    for (int i = 0; i < m->marker_count(); ++i) {
      const Eigen::Vector3d p = r * m->position(f, i);
      m->positions_m.row(f).segment<3>(3 * i) = p.transpose();
    }
  }
}

/// The marker set: --markerset (a built-in name or a JSON file), else the built-in one sharing
/// the most labels with the capture. Throws sim::InvalidArgument if none shares one.
models::MarkerSet choose_marker_set(const std::string& given, const mocap_io::MarkerData& markers,
                                    const std::string& capture_path) {
  models::MarkerSet set;
  if (given.empty()) {
    size_t best = 0;
    for (const std::string& name : models::builtin_marker_set_names()) {
      const models::MarkerSet candidate = models::builtin_marker_set(name);
      size_t shared = 0;
      for (const models::MarkerPlacement& p : candidate.markers) {
        shared += markers.find(p.name) >= 0 ? 1 : 0;
      }
      if (shared > best) {
        best = shared;
        set = candidate;
      }
    }
    if (best == 0) {
      std::string sets;
      for (const std::string& n : models::builtin_marker_set_names()) sets += " " + n;
      throw sim::InvalidArgument(capture_path + ": no built-in marker set (" + sets.substr(1) +
                                 ") shares a label with this capture; give --markerset "
                                 "FILE.json naming its labels: " +
                                 mocap_io::label_list(markers.labels));
    }
  } else if (given.find(".json") != std::string::npos) {
    set = models::parse_marker_set(read_file(given), given);
  } else {
    set = models::builtin_marker_set(given);
  }
  return set;
}

/// Scales `spec` to the subject and places its markers (OpenSim's ScaleTool) from `trial`
/// (`source` names it: the --static file, or the trial itself); returns the "scaling" statistics.
json scale_to_trial(const mocap_io::MarkerData& trial, const std::string& source, bool height_given,
                    const models::MarkerSet& set, models::CharacterSpec* spec,
                    std::vector<std::string>* warnings) {
  const mocap_io::ScaleResult scaled = mocap_io::scale_from_static(*spec, height_given, set, trial);
  *spec = scaled.spec;
  for (const std::string& u : scaled.unmeasured) warnings->push_back("not scaled: " + u);
  json factors = json::array();
  for (const mocap_io::ScaleFactor& f : scaled.factors) {
    factors.push_back({{"segments", f.segments},
                       {"measured_m", f.measured_m},
                       {"model_m", f.model_m},
                       {"factor", f.factor},
                       {"frames", f.frames}});
  }
  return {{"static_trial", source},
          {"height_m", spec->height_m},
          {"height_estimated", !height_given},
          {"factors", factors},
          {"unmeasured", scaled.unmeasured},
          {"placed_markers", scaled.placed},
          {"fixed_markers", set.fixed},
          {"static_rms_m", scaled.static_rms_m},
          {"static_max_m", scaled.static_max_m}};
}

/// Scales the body: from --static, else from the trial itself (a walk shows every segment),
/// else (--no-scaling, or the trial cannot scale it) by height only, with a warning.
json scale_body(const IkOptions& o, const mocap_io::MarkerData& trial,
                const std::string& capture_path, bool height_given, const models::MarkerSet& set,
                models::CharacterSpec* spec, std::vector<std::string>* warnings) {
  if (!o.static_trial.empty()) {
    MarkerFile stat = read_markers(o.static_trial, "--static");
    to_z_up(&stat.markers, o.lab_up);
    mocap_io::strip_subject_prefixes(&stat.markers);
    return scale_to_trial(stat.markers, o.static_trial, height_given, set, spec, warnings);
  }
  if (!o.no_scaling) {
    try {
      return scale_to_trial(trial, capture_path + " (the trial itself: no --static given)",
                            height_given, set, spec, warnings);
    } catch (const sim::InvalidArgument& e) {
      warnings->push_back(std::string("could not scale the body from the trial itself (") +
                          e.what() + "); give a static trial with --static");
    }
  }
  warnings->push_back("the body is the generic " + std::to_string(spec->height_m) +
                      " m character with generic marker placements (not scaled to the subject): "
                      "expect centimetres of marker error and biased joint angles");
  return {{"static_trial", nullptr}, {"height_m", spec->height_m}};
}

/// The marker errors over the solved frames.
struct IkErrors {
  int solved = 0;
  double rms_sum = 0.0, rms_max = 0.0, max_error = 0.0;  ///< m
  std::string max_marker;
  json per_frame = json::array();
};

IkErrors frame_errors(const mocap_io::MarkerIkResult& result, const mocap_io::MarkerData& markers) {
  IkErrors e;
  for (int f = 0; f < markers.frame_count(); ++f) {
    const mocap_io::MarkerIkFrame& fr = result.frames[static_cast<size_t>(f)];
    // A frame not fitted has no error (null); a refused one keeps the error that refused it.
    const bool fitted = fr.solved || fr.rejected;
    e.per_frame.push_back({{"solved", fr.solved},
                           {"rejected", fr.rejected},
                           {"rms", fitted ? json(fr.rms_error_m) : json(nullptr)},
                           {"max", fitted ? json(fr.max_error_m) : json(nullptr)},
                           {"markers", fr.markers_used},
                           {"iterations", fr.iterations}});
    if (!fr.solved) continue;
    ++e.solved;
    e.rms_sum += fr.rms_error_m;
    e.rms_max = std::max(e.rms_max, fr.rms_error_m);
    if (fr.max_error_m > e.max_error) {
      e.max_error = fr.max_error_m;
      e.max_marker = markers.labels[static_cast<size_t>(fr.max_error_marker)];
    }
  }
  return e;
}

/// Per-marker error over the solved frames (which markers the body cannot follow).
json marker_errors(const sim::Model& model, const mocap_io::MarkerData& markers,
                   const std::vector<double>& weights, const mocap_io::MarkerIkOptions& options,
                   const mocap_io::MarkerIkResult& result) {
  json per_marker = json::object();
  mocap_io::MarkerIk probe(*model, markers.labels, weights, options);
  const int n = markers.marker_count();
  std::vector<double> sq(static_cast<size_t>(n), 0.0), worst(static_cast<size_t>(n), 0.0);
  std::vector<int> seen(static_cast<size_t>(n), 0);
  std::vector<double> q(static_cast<size_t>(model->nq));
  for (int f = 0; f < markers.frame_count(); ++f) {
    if (!result.frames[static_cast<size_t>(f)].solved) continue;
    for (int k = 0; k < model->nq; ++k) q[static_cast<size_t>(k)] = result.qpos(f, k);
    const Eigen::Matrix3Xd sites = probe.marker_positions(q.data());
    for (int i = 0; i < n; ++i) {
      if (!markers.visible(f, i) || !sites.col(i).allFinite()) continue;
      const double e = (sites.col(i) - markers.position(f, i)).norm();
      sq[static_cast<size_t>(i)] += e * e;
      worst[static_cast<size_t>(i)] = std::max(worst[static_cast<size_t>(i)], e);
      ++seen[static_cast<size_t>(i)];
    }
  }
  for (int i = 0; i < n; ++i) {
    if (seen[static_cast<size_t>(i)] == 0) continue;
    per_marker[markers.labels[static_cast<size_t>(i)]] = {
        {"rms", std::sqrt(sq[static_cast<size_t>(i)] / seen[static_cast<size_t>(i)])},
        {"max", worst[static_cast<size_t>(i)]},
        {"frames", seen[static_cast<size_t>(i)]}};
  }
  return per_marker;
}

/// The solved motion, timed as the capture, with comments naming the capture and character.
mocap_io::Motion ik_motion(const sim::Model& model, const mocap_io::MarkerIkResult& result,
                           const mocap_io::MarkerData& markers, const std::string& capture_path,
                           const models::MarkerSet& set, const models::CharacterSpec& spec) {
  mocap_io::Motion motion;
  motion.columns = mocap_io::qpos_names(*model);
  motion.qpos = result.qpos;
  for (int f = 0; f < markers.frame_count(); ++f) motion.times_s.push_back(markers.time_s(f));
  motion.comments = {" biodyn mocap ik of " + capture_path + " (marker set " + set.name + ")",
                     " character: " + std::string(models::to_string(spec.sex)) + ", " +
                         std::to_string(spec.height_m) + " m, " + std::to_string(spec.mass_kg) +
                         " kg, detail " + models::to_string(spec.detail)};
  mocap_io::set_motion_body(&motion, spec);
  return motion;
}

/// The fit's warnings: a poor mean RMS, rejected frames, a body not upright or below the floor
/// (a wrong --lab-up) (status "warning" in the JSON).
void judge_fit(const IkErrors& e, const mjModel& m, const mocap_io::MarkerIkResult& result,
               const IkOptions& o, std::vector<std::string>* warnings) {
  const double mean = e.rms_sum / e.solved;
  if (mean > kTrustedRms_m) {
    warnings->push_back("marker RMS " + format_mm(mean) +
                        " over the solved frames (trusted below " + format_mm(kTrustedRms_m) +
                        "): the body or the marker set does not fit this capture");
  }
  if (result.rejected_count() > 0) {
    warnings->push_back(std::to_string(result.rejected_count()) +
                        " frames refused: their best fit was worse than " +
                        format_mm(o.max_frame_rms_m) +
                        " RMS (wrong data such as gaps stored as 0 0 0, or swapped labels); "
                        "they are written as unsolved (nan)");
  }
  // A capture read with the wrong vertical lies on its side or stands below the floor.
  const int pelvis = models::Rig(m).pelvis();
  sim::Data d(m);
  double up = 0.0, height = 0.0;
  for (int f = 0; f < static_cast<int>(result.frames.size()); ++f) {
    if (!result.frames[static_cast<size_t>(f)].solved) continue;
    for (int k = 0; k < m.nq; ++k) d->qpos[k] = result.qpos(f, k);
    mj_kinematics(&m, d.get());
    up += d->xmat[9 * pelvis + 8];  // the pelvis's z axis, world z component
    height += d->xpos[3 * pelvis + 2];
  }
  up /= e.solved;
  height /= e.solved;
  if (up < 0.7 || height < 0.3) {
    std::ostringstream w;
    w << "the body is not standing upright on the floor (pelvis " << height
      << " m up, its vertical axis " << kDegPerRad * std::acos(std::clamp(up, -1.0, 1.0))
      << " deg from the world's on average): is the lab's vertical axis " << o.lab_up
      << "? (--lab-up)";
    warnings->push_back(w.str());
  }
}

/// Every output's text, made before any is written: a failure leaves nothing half-written.
struct IkOutputs {
  std::string motion_csv, stats_json, body_json, mjcf;
};

/// <output without .csv>.body.json and .xml: the body the IK solved on.
std::string beside(const std::string& output, const std::string& suffix) {
  const std::string stem = output.size() > 4 && output.substr(output.size() - 4) == ".csv"
                               ? output.substr(0, output.size() - 4)
                               : output;
  return stem + suffix;
}

/// The console summary; warnings loudly, on stderr too.
void print_ik(const IkOptions& o, const IkErrors& e, const mocap_io::MarkerIkResult& result,
              const mocap_io::MarkerData& markers, const models::MarkerSet& set,
              const MarkerFile& capture, const std::vector<std::string>& prefixes,
              const std::vector<std::string>& warnings) {
  std::cout << "mocap ik: " << e.solved << "/" << markers.frame_count()
            << " frames solved (marker set " << set.name << ")";
  if (result.rejected_count() > 0) std::cout << ", " << result.rejected_count() << " refused";
  std::cout << ", marker RMS mean " << 1000 * e.rms_sum / e.solved << " mm, worst frame "
            << 1000 * e.rms_max << " mm, max " << 1000 * e.max_error << " mm (" << e.max_marker
            << "), " << static_cast<long>(result.solved_per_second()) << " solved frames/s\n";
  for (const std::string& p : prefixes) {
    std::cout << "  note: labels' subject prefix '" << p << ":' ignored\n";
  }
  for (const std::string& s : capture.inconsistencies) {
    std::cout << "  note: header and contents disagree: " << s << "\n";
  }
  for (const std::string& n : capture.notes) std::cout << "  note: " << n << "\n";
  for (const std::string& w : warnings) std::cerr << "WARNING: mocap ik: " << w << "\n";
  std::cout << "wrote " << o.output << ", " << beside(o.output, ".body.json") << " and "
            << beside(o.output, ".xml") << " (the body solved on)"
            << (o.json_path.empty() ? "" : " and " + o.json_path) << "\n";
}

int run_ik(const IkOptions& o, bool height_given) {
  if (o.c3d.empty() == o.trc.empty()) {
    throw sim::InvalidArgument("mocap ik: give exactly one of --c3d FILE or --trc FILE");
  }
  if (o.lab_up != "z" && o.lab_up != "y") {
    throw sim::InvalidArgument("--lab-up: expected z or y, got '" + o.lab_up + "'");
  }
  if (o.no_scaling && !o.static_trial.empty()) {
    throw sim::InvalidArgument("--no-scaling: not with --static (which scales the body)");
  }
  const std::string capture_path = o.c3d.empty() ? o.trc : o.c3d;
  check_outputs({{"-o", o.output},
                 {"-o (body file)", beside(o.output, ".body.json")},
                 {"-o (MJCF)", beside(o.output, ".xml")},
                 {"--json", o.json_path}},
                {capture_path, o.static_trial, o.character.body_path, o.character.overrides_path});
  MarkerFile capture = read_markers(capture_path, o.c3d.empty() ? "--trc" : "--c3d");
  to_z_up(&capture.markers, o.lab_up);
  const std::vector<std::string> prefixes = mocap_io::strip_subject_prefixes(&capture.markers);
  const mocap_io::MarkerData& markers = capture.markers;
  const models::MarkerSet set = choose_marker_set(o.markerset, markers, capture_path);
  models::CharacterSpec spec = o.character.to_spec();
  spec.markers = set.markers;
  json stats;
  std::vector<std::string> warnings;
  stats["scaling"] = scale_body(o, markers, capture_path, height_given, set, &spec, &warnings);
  const models::Character character = models::generate_character(spec);
  const std::string mjcf = models::to_mjcf(character);
  const sim::Model model = sim::Model::from_string(mjcf, "character");
  std::vector<double> weights;
  for (const std::string& label : markers.labels) weights.push_back(set.weight(label));
  mocap_io::MarkerIkOptions options;
  options.max_iterations = o.max_iterations;
  options.max_frame_rms_m = o.max_frame_rms_m;
  ProgressBar bar("mocap ik: " + std::to_string(markers.frame_count()) + " frames");
  const mocap_io::MarkerIkResult result = mocap_io::solve_marker_ik(
      *model, markers, weights, options, {},
      [](double fraction, void* user) { static_cast<ProgressBar*>(user)->update(fraction); }, &bar);
  bar.finish();
  const IkErrors e = frame_errors(result, markers);
  if (e.solved == 0) {
    const int rejected = result.rejected_count(), others = markers.frame_count() - rejected;
    std::string why;
    for (const std::string& w : warnings) why += "; " + w;
    throw sim::InvalidArgument(
        capture_path + ": no frame solved with the marker set '" + set.name + "' (" +
        std::to_string(rejected) + " fitted worse than " + format_mm(o.max_frame_rms_m) +
        " RMS and refused (--max-frame-rms)" +
        (others > 0 ? ", " + std::to_string(others) + " had too few visible markers" : "") + ")" +
        why + "; nothing written");
  }
  judge_fit(e, *model, result, o, &warnings);
  stats["per_marker"] = marker_errors(model, markers, weights, options, result);
  stats["frames"] = markers.frame_count();
  stats["frames_solved"] = e.solved;
  stats["frames_rejected"] = result.rejected_count();
  stats["rms_mean"] = e.rms_sum / e.solved;
  stats["rms_max"] = e.rms_max;
  stats["max_error"] = e.max_error;
  stats["max_error_marker"] = e.max_marker;
  stats["solved_frames_per_second"] = result.solved_per_second();
  stats["marker_set"] = set.name;
  stats["label_prefixes_ignored"] = prefixes;
  stats["unmapped_labels"] = json::array();
  const models::Rig rig(*model);
  for (const std::string& l : markers.labels) {
    if (rig.marker_site(l) < 0) stats["unmapped_labels"].push_back(l);
  }
  stats["inconsistencies"] = capture.inconsistencies;
  stats["reader_notes"] = capture.notes;
  stats["character"] = character_json(spec);
  stats["body_file"] = beside(o.output, ".body.json");
  stats["status"] = {{"level", warnings.empty() ? "ok" : "warning"},
                     {"rms_mean_m", e.rms_sum / e.solved},
                     {"warnings", warnings}};
  stats["per_frame"] = e.per_frame;
  IkOutputs out;
  out.motion_csv =
      mocap_io::format_motion_csv(ik_motion(model, result, markers, capture_path, set, spec));
  out.stats_json = json_text(stats, 1) + "\n";
  out.body_json = models::format_body_json(spec);
  out.mjcf = mjcf;
  write_file_atomically(o.output, out.motion_csv);
  write_file_atomically(beside(o.output, ".body.json"), out.body_json);
  write_file_atomically(beside(o.output, ".xml"), out.mjcf);
  if (!o.json_path.empty()) write_file_atomically(o.json_path, out.stats_json);
  print_ik(o, e, result, markers, set, capture, prefixes, warnings);
  return kExitOk;
}

}  // namespace

void run_capture_ik(const std::string& capture, const std::string& option,
                    const std::string& lab_up, const std::string& markerset,
                    const std::string& output, const std::string& json_path) {
  IkOptions o;
  const Format format = format_of(capture, option);
  if (format != Format::kC3d && format != Format::kTrc)
    throw sim::InvalidArgument(option + ": marker IK needs a .c3d or .trc capture, got '" +
                               capture + "'");
  (format == Format::kC3d ? o.c3d : o.trc) = capture;
  o.lab_up = lab_up;
  o.markerset = markerset;
  o.output = output;
  o.json_path = json_path;
  run_ik(o, false);
}

Command add_mocap_ik_command(CLI::App* mocap) {
  auto ik = std::make_shared<IkOptions>();
  CLI::App* ik_cmd = mocap->add_subcommand(
      "ik", "Marker IK of a capture on a generated character: joint trajectories (qpos CSV)");
  auto* c3d_opt = ik_cmd->add_option("--c3d", ik->c3d, "C3D capture");
  auto* trc_opt = ik_cmd->add_option("--trc", ik->trc, "TRC capture");
  c3d_opt->excludes(trc_opt);
  ik_cmd->add_option("--markerset", ik->markerset,
                     "built-in set (thesis26, full40, opensim_walking5) or a JSON file; default: "
                     "the built-in set sharing the most labels with the capture");
  ik_cmd->add_option("--static", ik->static_trial,
                     "static trial (.c3d/.trc) to scale the character and place markers from "
                     "(OpenSim's ScaleTool); without it the trial itself scales and places");
  ik_cmd->add_flag("--no-scaling", ik->no_scaling,
                   "keep the generic body scaled by height and its generic marker placements "
                   "(a warning says the fit is not to be trusted)");
  ik_cmd
      ->add_option("--max-frame-rms", ik->max_frame_rms_m,
                   "m: a frame fitted worse than this is refused (written as unsolved)")
      ->capture_default_str();
  ik_cmd->add_option("--lab-up", ik->lab_up, "vertical axis of the capture lab: z or y")
      ->capture_default_str();
  ik->character.add_to(ik_cmd);
  ik_cmd->add_option("--max-iterations", ik->max_iterations, "LM iterations per frame")
      ->capture_default_str();
  ik_cmd->add_option("-o,--output", ik->output, "motion CSV to write (qpos per frame)")->required();
  ik_cmd->add_option("--json", ik->json_path, "statistics JSON to write");
  return {ik_cmd, [ik, ik_cmd]() { return run_ik(*ik, ik_cmd->count("--height") > 0); }};
}

}  // namespace biodyn::apps
