// biodyn capture synth|run: optical marker capture (issue 27). Built only with the capture
// module (OpenCV); without it the command says what to install.
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "biodyn/sim/errors.h"
#include "cli_common.h"
#include "commands.h"
#ifdef BIODYN_HAVE_CAPTURE
#include "cmd_capture.h"
#endif

#ifdef BIODYN_HAVE_CAPTURE
#include <chrono>
#include <optional>
#include <sstream>

#include "biodyn/capture/blobs.h"
#include "biodyn/capture/evaluation.h"
#include "biodyn/capture/frame_source.h"
#include "biodyn/capture/intrinsics.h"
#include "biodyn/capture/overlay.h"
#include "biodyn/capture/pipeline.h"
#include "biodyn/capture/reconstruct.h"
#include "biodyn/capture/synthetic.h"
#include "biodyn/capture/t_pose.h"
#include "biodyn/mocap_io/marker_data.h"
#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/mocap_io/retarget.h"
#include "biodyn/mocap_io/trc.h"
#include "biodyn/models/body_file.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/simulation.h"
#include "biodyn/viewer/headless_gl.h"
#endif

namespace biodyn::apps {
namespace fs = std::filesystem;
using nlohmann::json;

#ifdef BIODYN_HAVE_CAPTURE
namespace {

struct SynthOptions {
  CharacterOptions body;
  std::string motion, output, size = "656x491";
  capture::SyntheticRigSpec rig;
  capture::ImageFormation formation;
  double marker_mm = 25, from_s = 0, duration_s = -1;
  double t_pose_s = 0.5;  ///< s held in a T-pose before the motion (0: none)
  bool landscape = false, in_place = false;
  int wand_frames = 1200;  ///< calibration recordings: the wand wave's frames at kCalibrationFps
  int board_views = 25;    ///< checkerboard views per camera (0: none)
};

// Hz: the calibration recordings keep a frame in five of a 100 Hz camera (a minute of waving
// in 1200 frames).
constexpr double kCalibrationFps = 20;
// Frames of the still L-frame recording.
constexpr int kLFrameFrames = 20;
// The nominal lenses' focal length error (a lens spec's tolerance), a fraction.
constexpr double kNominalFocalError = 0.03;

/// The calibration recordings of a synthetic capture, filmed by its rig with nothing else in
/// view: DIR/calibration/wand (the wand waved), DIR/calibration/lframe (the L-frame on the
/// floor), DIR/calibration/nominal.json (the lenses a lab would start from).
void film_calibration(const capture::Rig& rig, const capture::SyntheticRigSpec& spec,
                      const capture::ImageFormation& formation, int wand_frames,
                      const fs::path& dir) {
  sim::Simulation empty(sim::Model::from_string("<mujoco/>", "empty scene"));
  capture::SyntheticCameras cameras(empty.mutable_model(), rig, {}, formation);
  std::vector<std::string> names;
  for (const capture::Camera& c : rig.cameras) names.push_back(c.name);
  const capture::Wand wand;
  const capture::LFrame lframe;
  const auto wave = capture::wand_wave(wand, spec, wand_frames, kCalibrationFps, formation.seed);
  capture::FrameSet set;
  std::vector<std::vector<capture::MarkerView>> views;
  ProgressBar bar("capture synth: calibration (wand " + std::to_string(wand_frames) +
                  " frames, L-frame)");
  for (const char* what : {"wand", "lframe"}) {
    const bool is_wand = std::string(what) == "wand";
    capture::RecordedWriter writer((dir / "calibration" / what).string(), names, kCalibrationFps);
    const int frames = is_wand ? wand_frames : kLFrameFrames;
    for (int f = 0; f < frames; ++f) {
      std::vector<Eigen::Vector3d> points;
      if (is_wand) {
        points.assign(wave[f].begin(), wave[f].end());
      } else {
        for (const Eigen::Vector3d& p : lframe.points_W()) points.push_back(p);
      }
      set.index = f;
      cameras.film_points(empty.model(), empty.data(), points, is_wand ? f : wand_frames + f,
                          &set.images, &views);
      set.times_s.assign(rig.cameras.size(), f / kCalibrationFps);
      writer.add(set);
      bar.update(static_cast<double>(f + 1 + (is_wand ? 0 : wand_frames)) /
                 (wand_frames + kLFrameFrames));
    }
    const json about = is_wand ? json{{"source", "synthetic"},
                                      {"wand", {{"ab_m", wand.ab_m}, {"ac_m", wand.ac_m}}}}
                               : json{{"source", "synthetic"},
                                      {"lframe",
                                       {{"x1_m", lframe.x1_m},
                                        {"x2_m", lframe.x2_m},
                                        {"y_m", lframe.y_m},
                                        {"height_m", lframe.height_m}}}};
    writer.finish(about.dump());
  }
  bar.finish();
  capture::write_rig((dir / "calibration" / "nominal.json").string(),
                     capture::nominal_rig(rig, kNominalFocalError, formation.seed));
}

// s: the in-place option removes the root's horizontal path averaged over this window (a
// treadmill: the stride's sway stays, the progression goes).
constexpr double kInPlaceWindow_s = 1.0;

/// The motion on its body: a qpos CSV (its header's body unless the command line gives one) or
/// a BVH retargeted onto the command line's body.
mocap_io::Motion load_motion(const SynthOptions& o, models::CharacterSpec* spec,
                             std::vector<std::string>* notes) {
  if (lower_extension(o.motion) == ".bvh") {
    *spec = o.body.to_spec();
    return mocap_io::retarget_bvh_file(o.motion, *spec);
  }
  *spec = o.body.spec_for_motion(o.motion, notes);
  return mocap_io::read_motion_csv(o.motion);
}

/// Per frame of the motion: the horizontal offset that puts its root where the cameras look:
/// the mean root position moved to the target (or, in place, the root's 1 s running mean).
std::vector<Eigen::Vector2d> root_offsets(const mocap_io::Motion& m, const mjModel& model,
                                          const Eigen::Vector3d& target_W, bool in_place) {
  const int n = m.frame_count(), x = model.jnt_qposadr[0];
  std::vector<Eigen::Vector2d> offsets(static_cast<std::size_t>(n));
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int f = 0; f < n; ++f) mean += Eigen::Vector2d(m.qpos(f, x), m.qpos(f, x + 1));
  mean /= std::max(n, 1);
  for (int f = 0; f < n; ++f) {
    Eigen::Vector2d centre = mean;
    if (in_place) {
      Eigen::Vector2d sum = Eigen::Vector2d::Zero();
      int k = 0;
      for (int g = 0; g < n; ++g) {
        if (std::abs(m.times_s[g] - m.times_s[f]) > 0.5 * kInPlaceWindow_s) continue;
        sum += Eigen::Vector2d(m.qpos(g, x), m.qpos(g, x + 1));
        ++k;
      }
      centre = sum / k;
    }
    offsets[f] = target_W.head<2>() - centre;
  }
  return offsets;
}

// s: the T-pose lead-in moves from the T-pose into the motion's first frame over this time.
constexpr double kTPoseBlend_s = 1.0;

/// The part of `solved` that --from and --duration select, led in from a T-pose held
/// --t-pose seconds where it begins (a capture starts so: the labelling finds the subject).
mocap_io::Motion lead_in_from_t_pose(const mjModel& m, const mocap_io::Motion& solved,
                                     const SynthOptions& o) {
  const double t0 = solved.times_s.front() + o.from_s;
  const double t_end =
      o.duration_s > 0 ? std::min(solved.times_s.back(), t0 + o.duration_s) : solved.times_s.back();
  mocap_io::Motion part;
  part.columns = solved.columns;
  part.comments = solved.comments;
  std::vector<Eigen::Index> rows;
  for (int f = 0; f < solved.frame_count(); ++f) {
    if (solved.times_s[f] < t0 - 1e-9 || solved.times_s[f] > t_end + 1e-9) continue;
    rows.push_back(f);
    part.times_s.push_back(solved.times_s[f]);
  }
  if (rows.size() < 2)
    throw sim::InvalidArgument("--from " + std::to_string(o.from_s) + " s: past the motion's end");
  part.qpos = solved.qpos(rows, Eigen::all);
  return capture::with_t_pose_lead_in(m, part, o.t_pose_s, kTPoseBlend_s);
}

int run_synth(const SynthOptions& o) {
  check_outputs({{"-o", o.output, true}}, {o.motion});
  if (o.board_views != 0 && (o.board_views < 5 || o.board_views > 500))
    throw sim::InvalidArgument("--board-views: 0 (none) or 5 .. 500, got " +
                               std::to_string(o.board_views));
  if (o.wand_frames < 30 || o.wand_frames > 100000)
    throw sim::InvalidArgument(
        "--wand-frames: must be 30 .. 100000 (a calibration needs the "
        "wand seen from many places), got " +
        std::to_string(o.wand_frames));
  models::CharacterSpec spec;
  std::vector<std::string> notes;
  const mocap_io::Motion motion = load_motion(o, &spec, &notes);
  for (const std::string& n : notes) std::cout << "capture synth: note: " << n << "\n";
  const models::Character character = models::generate_character(spec);
  sim::Simulation sim(sim::Model::from_string(models::to_mjcf(character), "character"));
  mjModel& m = sim.mutable_model();
  mocap_io::check_motion_matches(motion, m, o.motion);
  mocap_io::Motion solved = mocap_io::longest_solved_span(motion);
  if (solved.frame_count() < 2)
    throw sim::InvalidArgument(o.motion + ": fewer than 2 solved frames");
  if (!(o.t_pose_s >= 0 && o.t_pose_s <= 60))
    throw sim::InvalidArgument("--t-pose: must be 0 .. 60 s, got " + std::to_string(o.t_pose_s));
  if (o.t_pose_s > 0) solved = lead_in_from_t_pose(m, solved, o);

  capture::SyntheticRigSpec rig_spec = o.rig;
  std::tie(rig_spec.width_px, rig_spec.height_px) = parse_size(o.size, "--size");
  rig_spec.portrait = !o.landscape;
  const capture::Rig rig = capture::make_synthetic_rig(rig_spec);
  capture::ImageFormation formation = o.formation;
  formation.marker_diameter_m = o.marker_mm / 1000;
  std::vector<int> sites;
  mocap_io::MarkerData truth;
  truth.rate_hz = rig_spec.fps;
  for (const models::Marker& mk : character.markers) {
    sites.push_back(mj_name2id(&m, mjOBJ_SITE, ("marker_" + mk.name).c_str()));
    truth.labels.push_back(mk.name);
  }
  const std::vector<Eigen::Vector2d> offsets =
      root_offsets(solved, m, rig_spec.target_W, o.in_place);
  const double t0 = solved.times_s.front() + (o.t_pose_s > 0 ? 0 : o.from_s);
  const double t_end = o.duration_s > 0 && o.t_pose_s == 0
                           ? std::min(solved.times_s.back(), t0 + o.duration_s)
                           : solved.times_s.back();
  if (!(t_end > t0))
    throw sim::InvalidArgument("--from " + std::to_string(o.from_s) + " s: past the motion's end");
  const int frames = static_cast<int>(std::floor((t_end - t0) * rig_spec.fps)) + 1;

  viewer::HeadlessGl gl;
  capture::SyntheticCameras cameras(m, rig, sites, formation);
  std::vector<std::string> names;
  for (const capture::Camera& c : rig.cameras) names.push_back(c.name);
  capture::RecordedWriter writer(o.output, names, rig_spec.fps);
  truth.positions_m.resize(frames, 3 * static_cast<int>(sites.size()));
  mocap_io::Motion filmed;  // the poses as filmed (the root moved into the volume)
  filmed.columns = mocap_io::qpos_names(m);
  filmed.qpos.resize(frames, m.nq);
  mocap_io::set_motion_body(&filmed, spec);
  std::vector<std::string> truth2d(rig.cameras.size(), "frame,marker,u_px,v_px,visible,whole\n");
  capture::FrameSet set;
  std::vector<std::vector<capture::MarkerView>> views;
  long visible = 0, out_of_view = 0;
  ProgressBar bar("capture synth: " + std::to_string(frames) + " frames x " +
                  std::to_string(rig.size()) + " cameras");
  for (int f = 0; f < frames; ++f) {
    const double t = t0 + f / rig_spec.fps;
    std::size_t f0 = 0;
    double a = 0;
    sim::bracket_time(solved.times_s, t, &f0, &a);
    const auto r0 = static_cast<Eigen::Index>(f0);
    sim::interpolate_qpos(m, solved.qpos.row(r0), solved.qpos.row(r0 + 1), a, sim.data().qpos);
    const Eigen::Vector2d shift = (1 - a) * offsets[f0] + a * offsets[f0 + 1];
    sim.data().qpos[m.jnt_qposadr[0]] += shift.x();
    sim.data().qpos[m.jnt_qposadr[0] + 1] += shift.y();
    sim.forward();
    filmed.times_s.push_back(f / rig_spec.fps);
    for (int i = 0; i < m.nq; ++i) filmed.qpos(f, i) = sim.data().qpos[i];
    set.index = f;
    cameras.film(m, sim.data(), f, &set.images, &views);
    set.times_s.assign(rig.cameras.size(), f / rig_spec.fps);
    writer.add(set);
    for (std::size_t k = 0; k < sites.size(); ++k) {
      truth.positions_m.row(f).segment<3>(3 * static_cast<Eigen::Index>(k)) =
          Eigen::Vector3d(sim.data().site_xpos + 3 * sites[k]).transpose();
      int seen = 0;
      for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
        const capture::MarkerView& v = views[c][k];
        std::ostringstream line;
        line.precision(9);
        line << f << "," << truth.labels[k] << "," << v.uv_px.x() << "," << v.uv_px.y() << ","
             << (v.visible ? 1 : 0) << "," << (v.whole ? 1 : 0) << "\n";
        truth2d[c] += line.str();
        seen += v.visible ? 1 : 0;
        out_of_view += rig.cameras[c].in_image(v.uv_px) ? 0 : 1;
      }
      visible += seen >= 2 ? 1 : 0;
    }
    bar.update(static_cast<double>(f + 1) / frames);
  }
  bar.finish();
  const fs::path dir(writer.partial_dir());
  film_calibration(rig, rig_spec, formation, o.wand_frames, dir);
  if (o.board_views > 0) {
    std::cout << "capture synth: checkerboard, " << o.board_views << " views per camera\n";
    capture::film_board_views(rig, capture::Checkerboard{}, o.board_views,
                              formation.sensor_noise_grey, formation.seed,
                              (dir / "calibration" / "checkerboard").string());
  }
  for (std::size_t c = 0; c < rig.cameras.size(); ++c)
    write_file_atomically((dir / "truth" / (names[c] + ".csv")).string(), truth2d[c]);
  mocap_io::write_trc((dir / "truth" / "markers.trc").string(), truth, "mm");
  write_file_atomically((dir / "truth" / "motion.csv").string(),
                        mocap_io::format_motion_csv(filmed));
  capture::write_rig((dir / "rig_truth.json").string(), rig);
  const double marker_frames = static_cast<double>(frames) * static_cast<double>(sites.size());
  const double seen_twice = static_cast<double>(visible) / marker_frames;
  const double outside = static_cast<double>(out_of_view) / (marker_frames * rig.size());
  const json extra = {{"source", "synthetic"},
                      {"motion", o.motion},
                      {"motion_from_s", t0 - solved.times_s.front()},
                      {"in_place", o.in_place},
                      {"body", character_json(spec)},
                      // The subject's body as a lab would measure it (capture run labels with it).
                      {"subject", json::parse(models::format_body_json(spec, true))},
                      {"t_pose_s", o.t_pose_s},
                      {"markers", truth.labels},
                      {"marker_diameter_m", formation.marker_diameter_m},
                      {"noise_px", formation.noise_px},
                      {"sensor_noise_grey", formation.sensor_noise_grey},
                      {"exposure", formation.exposure},
                      {"seed", formation.seed},
                      {"rig_truth", "rig_truth.json"},
                      {"truth",
                       {{"markers", "truth/markers.trc"},
                        {"views", "truth/<camera>.csv"},
                        {"motion", "truth/motion.csv"}}},
                      {"markers_seen_by_2_cameras", seen_twice},
                      {"marker_views_outside_image", outside}};
  writer.finish(extra.dump());
  std::cout << "capture synth: " << frames << " frames from " << rig.size() << " cameras ("
            << rig_spec.width_px << " x " << rig_spec.height_px << " px, " << rig_spec.fps
            << " fps) in " << o.output << "; markers seen by >= 2 cameras: " << 100 * seen_twice
            << "% of marker-frames\n";
  if (outside > 0.01)
    std::cout << "capture synth: WARNING: " << 100 * outside
              << "% of marker views fall outside the images (the motion leaves the volume: "
                 "--in-place keeps it on a treadmill)\n";
  return kExitOk;
}

struct RunOptions {
  std::string dir, rig_path, points_path, summary_path, overlay_path;
  double overlay_scale = 0.5;
  LabelOptions label;
  std::vector<std::string> live;
  int live_frames = 0, threads = 0;
  capture::BlobParams blobs;
  capture::ReconstructionParams reconstruction;
  bool tracking_2d = true;  ///< 2D blob tracks carry last frame's points (tracking2d.h)
};

/// A synthetic capture's truth: each marker's position per frame and each camera's views.
struct Truth {
  mocap_io::MarkerData markers;
  std::vector<std::vector<std::vector<capture::MarkerView>>> views;  // [camera][frame][marker]
};

std::optional<Truth> read_truth(const std::string& dir, const std::vector<std::string>& cameras) {
  const fs::path t = fs::path(dir) / "truth";
  if (!fs::exists(t / "markers.trc")) return std::nullopt;
  Truth truth;
  truth.markers = mocap_io::read_trc((t / "markers.trc").string()).markers;
  const int n = truth.markers.marker_count(), frames = truth.markers.frame_count();
  for (const std::string& c : cameras) {
    const std::string path = (t / (c + ".csv")).string();
    const std::string text = sim::read_file(path);
    std::vector<std::vector<capture::MarkerView>> per(frames, std::vector<capture::MarkerView>(n));
    std::istringstream in(text);
    std::string line;
    std::getline(in, line);  // header
    for (int row = 0; row < frames * n; ++row) {
      if (!std::getline(in, line))
        throw sim::InvalidArgument(path + ": fewer rows than frames x markers");
      const std::vector<std::string> f = sim::split_fields(line, ',');
      if (f.size() != 5 && f.size() != 6)
        throw sim::InvalidArgument(path + ": line " + std::to_string(row + 2) +
                                   ": expected 6 fields (frame,marker,u_px,v_px,visible,whole)");
      capture::MarkerView& v = per[row / n][row % n];
      v.uv_px = Eigen::Vector2d(std::stod(f[2]), std::stod(f[3]));
      v.visible = f[4] == "1";
      v.whole = f.size() == 6 ? f[5] == "1" : v.visible;  // older captures: no such column
    }
    truth.views.push_back(std::move(per));
  }
  return truth;
}

/// Fills, writes and solves the labelled capture, and says how it went.
json finish_labelling(LabelStage* labels, const LabelOptions& o) {
  const json l = labels->finish(o);
  if (!l["labelled"].get<bool>()) {
    std::cout << "capture run: WARNING: no frame showed the subject in a T-pose: nothing "
                 "labelled (a capture starts with the subject standing arms out)\n";
    return l;
  }
  std::cout << "capture run: labelled from frame " << l["initialised_at_frame"] << ": "
            << 100 * l["labelled_marker_frames"].get<double>()
            << "% of marker-frames; gaps filled: " << l["gap_fill"]["spline_samples"]
            << " samples by cubic, " << l["gap_fill"]["skeleton_samples"] << " by the skeleton, "
            << l["gap_fill"]["left_samples"] << " left\n";
  if (l.contains("truth"))
    std::cout << "capture run: labels against the truth: "
              << 100 * l["truth"]["labelled_right"].get<double>()
              << "% of reconstructed marker-frames labelled right, " << l["truth"]["wrong_labels"]
              << " wrong labels (" << l["truth"]["identity_swaps"] << " identity swaps)\n";
  if (l.contains("truth_motion"))
    std::cout << "capture run: skeleton (marker IK) against the filmed motion: joint angles "
              << l["truth_motion"]["seen_joint_rms_deg"].get<double>()
              << " deg RMS over the joints a marker moves, "
              << l["truth_motion"]["joint_rms_deg"].get<double>() << " deg over all (worst "
              << l["truth_motion"]["worst_joint"].get<std::string>() << " "
              << l["truth_motion"]["worst_joint_rms_deg"].get<double>() << " deg)\n";
  return l;
}

int run_capture(const RunOptions& o) {
  if (o.points_path.empty() && !o.label.wanted() && o.overlay_path.empty())
    throw sim::InvalidArgument(
        "capture run: nothing to write: give -o markers.c3d|.trc (labelled), --motion-out "
        "motion.csv (the skeleton) or --points points.csv (unlabelled)");
  o.label.validate();
  std::vector<OutputPath> outputs;
  for (const auto& [option, path] : {std::pair<const char*, std::string>{"--points", o.points_path},
                                     {"--summary", o.summary_path},
                                     {"-o", o.label.markers_out},
                                     {"--overlay", o.overlay_path},
                                     {"--motion-out", o.label.motion_out}})
    if (!path.empty()) outputs.push_back({option, path, false});
  check_outputs(outputs, {o.dir});
  std::string subject_note;  // before the cameras are opened: a missing subject fails at once
  const models::CharacterSpec subject =
      o.label.wanted() ? capture_subject(o.dir, o.label, &subject_note) : models::CharacterSpec{};
  const std::string rig_path = capture_rig_path(o.dir, o.rig_path);
  const capture::Rig rig = capture::read_rig(rig_path);
  o.label.validate_filter(rig.cameras.front().fps);
  std::vector<std::string> names;
  for (const capture::Camera& c : rig.cameras) names.push_back(c.name);
  std::unique_ptr<capture::FrameSource> source =
      o.live.empty() ? capture::open_recorded(o.dir, names)
                     : capture::open_live(o.live, rig.cameras.front().fps, o.live_frames);
  if (source->camera_count() != rig.size())
    throw sim::InvalidArgument(rig_path + ": " + std::to_string(rig.size()) +
                               " cameras, the source has " +
                               std::to_string(source->camera_count()));
  const std::optional<Truth> truth = o.live.empty() ? read_truth(o.dir, names) : std::nullopt;
  std::unique_ptr<LabelStage> labels;
  LabelTruth label_truth;
  if (o.label.wanted()) {
    std::cout << "capture run: labelling with " << subject_note << " (" << subject.height_m
              << " m, " << subject.mass_kg << " kg)\n";
    if (truth) {
      label_truth.markers = truth->markers;
      const fs::path motion = fs::path(o.dir) / "truth" / "motion.csv";
      if (fs::exists(motion)) label_truth.motion_path = motion.string();
    }
    labels = std::make_unique<LabelStage>(subject, rig.cameras.front().fps,
                                          truth ? &label_truth : nullptr);
  }
  capture::set_image_threads(o.threads);
  const capture::Tracking2dParams tracking;
  capture::CapturePipeline pipeline(rig, o.blobs, o.reconstruction,
                                    o.tracking_2d ? &tracking : nullptr);
  std::unique_ptr<capture::OverlayWriter> overlay =
      o.overlay_path.empty() ? nullptr
                             : std::make_unique<capture::OverlayWriter>(
                                   o.overlay_path, rig, rig.cameras.front().fps, o.overlay_scale);
  std::vector<capture::Point3> points;
  capture::CaptureScore score;
  std::ostringstream csv;
  csv << "frame,time_s,point,x_m,y_m,z_m,views,residual_px\n";
  csv.precision(9);
  double read_s = 0, process_s = 0;
  long point_total = 0, dropped = 0, continued = 0;
  int frames = 0;
  capture::FrameSet set;
  const int total = source->frame_count();
  ProgressBar bar("capture run: " +
                  (total > 0 ? std::to_string(total) + " frames" : std::string("live")));
  using clock = std::chrono::steady_clock;
  while (true) {
    const auto t0 = clock::now();
    if (!source->next(&set)) break;
    const auto t1 = clock::now();
    pipeline.process(set, &points);
    const auto t2 = clock::now();
    read_s += std::chrono::duration<double>(t1 - t0).count();
    process_s += std::chrono::duration<double>(t2 - t1).count();
    for (int d : set.dropped_before) dropped += d;
    for (std::size_t p = 0; p < points.size(); ++p) {
      const capture::Point3& pt = points[p];
      csv << set.index << "," << set.times_s.front() << "," << p << "," << pt.p_W.x() << ","
          << pt.p_W.y() << "," << pt.p_W.z() << "," << pt.views.size() << "," << pt.residual_px
          << "\n";
    }
    point_total += static_cast<long>(points.size());
    continued += pipeline.continued_points();
    if (labels) labels->add(points);
    if (overlay)
      overlay->add(
          set, pipeline.blobs(),
          labels ? labels->latest() : std::vector<std::pair<std::string, Eigen::Vector3d>>{});
    if (truth && set.index < truth->markers.frame_count()) {
      std::vector<Eigen::Vector3d> truth_W;
      std::vector<int> seen(truth->markers.marker_count(), 0);
      for (int k = 0; k < truth->markers.marker_count(); ++k) {
        truth_W.push_back(truth->markers.position(set.index, k));
        for (int c = 0; c < rig.size(); ++c)
          seen[k] += truth->views[c][set.index][k].visible ? 1 : 0;
      }
      for (int c = 0; c < rig.size(); ++c)
        capture::score_detection(pipeline.blobs()[c], truth->views[c][set.index], &score);
      capture::score_points(points, truth_W, seen, &score);
    }
    ++frames;
    if (total > 0) bar.update(static_cast<double>(frames) / total);
  }
  bar.finish();
  if (!o.points_path.empty()) write_file_atomically(o.points_path, csv.str());
  if (overlay) overlay->finish();
  json summary = {
      {"capture", o.dir},
      {"rig", rig_path},
      {"rig_source", rig.source},
      {"cameras", rig.size()},
      {"frames", frames},
      {"dropped_frames", dropped},
      {"points_per_frame", frames ? static_cast<double>(point_total) / frames : 0.0},
      {"read_s", read_s},
      {"process_s", process_s},
      {"process_frames_per_s", frames / std::max(process_s, 1e-9)},
      {"labelled", static_cast<bool>(labels)},
      {"tracking_2d",
       {{"on", o.tracking_2d},
        {"points_continued",
         point_total ? static_cast<double>(continued) / static_cast<double>(point_total) : 0.0},
        {"about",
         "the share of points that continue a point of the frame before along "
         "their blobs' 2D tracks (taken before any new match)"}}}};
  if (labels) summary["labelling"] = finish_labelling(labels.get(), o.label);
  std::cout << "capture run: " << frames << " frames, " << rig.size() << " cameras (" << rig_path
            << "): " << summary["points_per_frame"].get<double>()
            << " points per frame; processing " << summary["process_frames_per_s"].get<double>()
            << " frames/s (reading the images " << frames / std::max(read_s, 1e-9)
            << " frames/s)\n";
  if (dropped > 0)
    std::cout << "capture run: WARNING: " << dropped << " frames dropped by the cameras' clocks\n";
  if (truth) {
    summary["truth"] = {{"detection_recall", score.detection_recall()},
                        {"detection_recall_whole_in_image", score.whole_detection_recall()},
                        {"extra_blobs", score.extra_blobs},
                        {"point_recall", score.point_recall()},
                        {"rms_mm", 1000 * score.rms_m()},
                        {"worst_mm", 1000 * score.worst_m},
                        {"ghost_points", score.ghost_points}};
    std::cout << "capture run: against the truth: detection recall "
              << 100 * score.detection_recall() << "% of visible marker views ("
              << 100 * score.whole_detection_recall()
              << "% of those whose whole image is in the frame), 3D points found "
              << 100 * score.point_recall() << "% of markers seen by >= 2 cameras, RMS "
              << 1000 * score.rms_m() << " mm (worst " << 1000 * score.worst_m << " mm), "
              << score.ghost_points << " ghost points\n";
  }
  if (!o.summary_path.empty()) write_file_atomically(o.summary_path, json_text(summary, 2));
  return kExitOk;
}

struct CalibrateOptions {
  std::string dir, nominal_path, output;
  std::string intrinsics = "auto";  ///< auto | checkerboard | nominal
  std::string board = "9x6";
  double square_mm = 40;
  capture::Wand wand;
  capture::LFrame lframe;
  capture::BlobParams blobs;
  capture::CalibrationParams params;
};

/// The wand in every camera's images of a recorded wave.
capture::WandObservations observe_wand(capture::FrameSource* source, const capture::Wand& wand,
                                       const capture::BlobParams& params) {
  const int n = source->camera_count();
  capture::WandObservations seen;
  seen.abc_px.resize(n);
  seen.seen.resize(n);
  std::vector<capture::BlobDetector> detectors(n, capture::BlobDetector(params));
  std::vector<capture::Blob> blobs;
  capture::FrameSet set;
  while (source->next(&set)) {
    for (int c = 0; c < n; ++c) {
      detectors[c].detect(set.images[c], &blobs);
      std::array<Eigen::Vector2d, 3> abc;
      const bool ok = capture::identify_wand(blobs, wand, &abc);
      seen.abc_px[c].push_back(abc);
      seen.seen[c].push_back(ok ? 1 : 0);
    }
  }
  return seen;
}

/// The lenses of `rig`'s cameras from DIR/calibration/checkerboard (intrinsics.h) when
/// --intrinsics says so (auto: when the folder is there); what they came from, per camera.
json lenses_from_checkerboard(const CalibrateOptions& o, capture::Rig* rig) {
  if (o.intrinsics != "auto" && o.intrinsics != "checkerboard" && o.intrinsics != "nominal")
    throw sim::InvalidArgument("--intrinsics: auto, checkerboard or nominal, got \"" +
                               o.intrinsics + "\"");
  const fs::path folder = fs::path(o.dir) / "calibration" / "checkerboard";
  const bool use = o.intrinsics == "checkerboard" || (o.intrinsics == "auto" && fs::exists(folder));
  if (!use) return {{"source", "nominal lenses (refined by the bundle adjustment)"}};
  capture::Checkerboard board;
  std::tie(board.cols, board.rows) = parse_size(o.board, "--board");
  board.square_m = o.square_mm / 1000;
  board.validate();
  json cams = json::array();
  for (capture::Camera& cam : rig->cameras) {
    const capture::LensFit fit =
        capture::calibrate_lens(capture::read_board_views(folder.string(), cam.name), board);
    if (fit.lens.width_px != cam.K.width_px || fit.lens.height_px != cam.K.height_px)
      throw sim::InvalidArgument(
          folder.string() + "/" + cam.name + ": images are " + std::to_string(fit.lens.width_px) +
          " x " + std::to_string(fit.lens.height_px) + ", the camera's " +
          std::to_string(cam.K.width_px) + " x " + std::to_string(cam.K.height_px));
    cam.K = fit.lens;
    std::cout << "  " << cam.name << ": lens from " << fit.views_used
              << " checkerboard views, reprojection " << fit.rms_px << " px\n";
    cams.push_back({{"name", cam.name}, {"views", fit.views_used}, {"rms_px", fit.rms_px}});
  }
  return {{"source", "checkerboard (then refined by the bundle adjustment)"},
          {"board", {{"inner_corners", o.board}, {"square_mm", o.square_mm}}},
          {"cameras", cams}};
}

int run_calibrate(const CalibrateOptions& o) {
  const fs::path dir(o.dir), cal = dir / "calibration";
  const std::string nominal_path =
      o.nominal_path.empty() ? (cal / "nominal.json").string() : o.nominal_path;
  const std::string output = o.output.empty() ? (dir / "rig.json").string() : o.output;
  check_outputs({{"-o", output, false}}, {nominal_path});
  capture::Rig nominal = capture::read_rig(nominal_path);
  std::vector<std::string> names;
  for (const capture::Camera& c : nominal.cameras) names.push_back(c.name);
  const auto t0 = std::chrono::steady_clock::now();
  const json lenses = lenses_from_checkerboard(o, &nominal);
  auto wand_source = capture::open_recorded((cal / "wand").string(), names);
  const capture::WandObservations seen = observe_wand(wand_source.get(), o.wand, o.blobs);
  capture::CalibrationReport report;
  capture::Rig rig = capture::calibrate_from_wand(nominal, seen, o.wand, o.params, &report);
  // The L-frame, reconstructed with the calibrated rig, sets the lab frame.
  auto lframe_source = capture::open_recorded((cal / "lframe").string(), names);
  // Before the alignment the world is a camera's frame: no lab volume to keep points in.
  capture::ReconstructionParams anywhere;
  anywhere.volume_min_W = Eigen::Vector3d::Constant(-1e3);
  anywhere.volume_max_W = Eigen::Vector3d::Constant(1e3);
  capture::CapturePipeline pipeline(rig, o.blobs, anywhere);
  std::vector<std::vector<capture::Point3>> lframe_points;
  capture::FrameSet set;
  while (lframe_source->next(&set)) {
    lframe_points.emplace_back();
    pipeline.process(set, &lframe_points.back());
  }
  double fit_m = 0;
  capture::align_to_lframe(lframe_points, o.lframe, &rig, &fit_m);
  report.lframe_fit_rms_mm = 1000 * fit_m;
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  capture::write_rig(output, rig);
  json cams = json::array();
  std::cout << "capture calibrate: " << rig.size() << " cameras from " << seen.frames()
            << " wand frames (" << report.frames_used << " seen by >= 2 cameras), "
            << report.iterations << " bundle-adjustment iterations, " << wall_s << " s\n";
  const fs::path truth_path = dir / "rig_truth.json";
  const std::optional<capture::Rig> truth =
      fs::exists(truth_path) ? std::optional<capture::Rig>(capture::read_rig(truth_path.string()))
                             : std::nullopt;
  double worst_centre_mm = 0;
  for (int c = 0; c < rig.size(); ++c) {
    const capture::Camera& cam = rig.cameras[c];
    json j = {{"name", cam.name},
              {"reprojection_rms_px", report.reprojection_rms_px[c]},
              {"wand_views", report.wand_views[c]}};
    std::cout << "  " << cam.name << ": reprojection RMS " << report.reprojection_rms_px[c]
              << " px over " << report.wand_views[c] << " wand views";
    if (truth && truth->find(cam.name) >= 0) {
      const capture::Camera& t = truth->cameras[truth->find(cam.name)];
      const double centre_mm = 1000 * (cam.p_WC - t.p_WC).norm();
      const double focal_pct = 100 * (cam.K.fx_px / t.K.fx_px - 1);
      worst_centre_mm = std::max(worst_centre_mm, centre_mm);
      j["truth"] = {{"centre_error_mm", centre_mm}, {"focal_error_percent", focal_pct}};
      std::cout << "; against the truth: centre " << centre_mm << " mm off, focal length "
                << focal_pct << "%";
    }
    std::cout << "\n";
    cams.push_back(j);
  }
  std::cout << "capture calibrate: wand length (A to C, triangulated) RMS error "
            << report.wand_ac_rms_mm << " mm; L-frame fit " << report.lframe_fit_rms_mm
            << " mm; wrote " << output << "\n";
  if (truth)
    std::cout << "capture calibrate: against the truth: camera centres within " << worst_centre_mm
              << " mm\n";
  json summary = {{"rig", output},
                  {"nominal", nominal_path},
                  {"lenses", lenses},
                  {"wand", {{"ab_m", o.wand.ab_m}, {"ac_m", o.wand.ac_m}}},
                  {"wand_frames", seen.frames()},
                  {"wand_frames_used", report.frames_used},
                  {"wand_ac_rms_mm", report.wand_ac_rms_mm},
                  {"lframe_fit_rms_mm", report.lframe_fit_rms_mm},
                  {"iterations", report.iterations},
                  {"solver", report.solver},
                  {"wall_s", wall_s},
                  {"cameras", cams}};
  if (truth) summary["truth_worst_centre_error_mm"] = worst_centre_mm;
  write_file_atomically((fs::path(output).parent_path() / "calibration_report.json").string(),
                        json_text(summary, 2));
  return kExitOk;
}

/// `capture run`'s options into `r`.
void add_run_options(CLI::App* run, RunOptions* r) {
  run->add_option("dir", r->dir, "recorded capture folder (capture synth writes one)")->required();
  run->add_option(
      "--rig", r->rig_path,
      "camera rig JSON (default: DIR/rig.json, else the synthetic truth DIR/rig_truth.json)");
  run->add_option("--live", r->live,
                  "live cameras instead: V4L2 devices (/dev/video0 or 0) or "
                  "video files played in real time, in the rig's order, comma-separated")
      ->delimiter(',');
  run->add_option("--live-frames", r->live_frames,
                  "stop a live capture after this many frames (0: never)")
      ->capture_default_str();
  run->add_option("--threshold", r->blobs.threshold_grey,
                  "grey levels above the background that make a marker")
      ->capture_default_str();
  run->add_option("--min-views", r->reconstruction.min_views, "cameras a 3D point needs")
      ->capture_default_str();
  run->add_option("--epipolar-gate", r->reconstruction.epipolar_gate_px, "px")
      ->capture_default_str();
  run->add_option("--threads", r->threads, "threads for the cameras' images (0: OpenCV's default)")
      ->capture_default_str();
  run->add_flag("!--no-2d-tracks", r->tracking_2d,
                "reconstruct every frame on its own (no 2D blob tracks carrying last frame's "
                "points)");
  run->add_option("-o,--output", r->label.markers_out,
                  "labelled markers to write: .c3d or .trc (gaps filled as --fill says)");
  run->add_option("--motion-out", r->label.motion_out,
                  "the subject's skeleton motion (qpos CSV) by marker IK of the labelled markers");
  run->add_option("--fill", r->label.fill,
                  "gap filling: none, spline (gaps up to --max-gap) or skeleton (longer gaps "
                  "carried by the fitted skeleton's segment)")
      ->capture_default_str();
  run->add_option("--max-gap", r->label.max_gap_s, "s, longest gap a cubic fills")
      ->capture_default_str();
  run->add_option("--filter-hz", r->label.filter_hz,
                  "low-pass cut-off of the markers the skeleton is solved from (zero-lag "
                  "Butterworth; the written markers stay unfiltered): auto (each marker's by "
                  "Winter's residual analysis) or Hz (0: unfiltered)")
      ->capture_default_str();
  r->label.subject.add_to(run, false);
  run->add_option("--points", r->points_path, "CSV of the unlabelled 3D points per frame");
  run->add_option("--overlay", r->overlay_path,
                  "video (.mp4 or .avi) of every camera's images with the detected blobs and "
                  "the labelled markers drawn on them");
  run->add_option("--overlay-scale", r->overlay_scale, "the overlay's tiles, times the image size")
      ->capture_default_str();
  run->add_option("--summary", r->summary_path, "JSON summary to write");
}

}  // namespace
#endif  // BIODYN_HAVE_CAPTURE

Command add_capture_command(CLI::App* app) {
  CLI::App* cmd = app->add_subcommand(
      "capture", "Optical marker capture: synthetic cameras, camera images to 3D markers");
#ifdef BIODYN_HAVE_CAPTURE
  cmd->require_subcommand(1);
  auto s = std::make_shared<SynthOptions>();
  CLI::App* synth = cmd->add_subcommand(
      "synth", "Film a motion's markers with virtual cameras: images, timestamps, ground truth");
  synth->add_option("--motion", s->motion, "qpos CSV (mocap ik/retarget/walk) or BVH")->required();
  s->body.add_to(synth);
  synth->add_option("--cameras", s->rig.cameras, "cameras on a ring around the volume")
      ->capture_default_str();
  synth
      ->add_option("--distance", s->rig.distance_m,
                   "cameras' horizontal distance from the volume's axis, m")
      ->capture_default_str();
  synth->add_option("--size", s->size, "image size WIDTHxHEIGHT, px")->capture_default_str();
  synth->add_option("--fps", s->rig.fps, "frames per second")->capture_default_str();
  synth->add_flag("--landscape", s->landscape,
                  "cameras not rolled (the image's long side horizontal)");
  synth
      ->add_option("--rig-seed", s->rig.jitter_seed,
                   "0: an even ring; otherwise each camera's place and aim jittered from this seed")
      ->capture_default_str();
  synth->add_option("--k1", s->rig.k1, "radial distortion k1 of every lens")->capture_default_str();
  synth->add_option("--k2", s->rig.k2, "radial distortion k2")->capture_default_str();
  synth
      ->add_option("--noise-px", s->formation.noise_px,
                   "each marker's image position noise (SD), px")
      ->capture_default_str();
  synth
      ->add_option("--sensor-noise", s->formation.sensor_noise_grey,
                   "per-pixel noise (SD), grey levels")
      ->capture_default_str();
  synth
      ->add_option("--exposure", s->formation.exposure,
                   "brightness gain (markers at 255 x exposure)")
      ->capture_default_str();
  synth->add_option("--marker-mm", s->marker_mm, "marker diameter, mm")->capture_default_str();
  synth->add_option("--seed", s->formation.seed, "the noises' random seed")->capture_default_str();
  synth->add_option("--from", s->from_s, "start this far into the motion, s")
      ->capture_default_str();
  synth->add_option("--duration", s->duration_s,
                    "film this long, s (default: to the motion's end)");
  synth
      ->add_option("--t-pose", s->t_pose_s,
                   "s the subject stands in a T-pose before the motion (then 1 s into its "
                   "first frame), for the labelling; 0: none")
      ->capture_default_str();
  synth->add_flag("--in-place", s->in_place,
                  "remove the root's progression (its 1 s running mean): a walk on a treadmill");
  synth
      ->add_option("--wand-frames", s->wand_frames,
                   "frames of the calibration wand's wave (at 20 fps; 1200: a minute)")
      ->capture_default_str();
  synth
      ->add_option("--board-views", s->board_views,
                   "checkerboard views per camera for the lenses (9x6 inner corners, 40 mm; 0: "
                   "none)")
      ->capture_default_str();
  synth->add_option("-o,--output", s->output, "capture folder to write (must not exist)")
      ->required();
  auto r = std::make_shared<RunOptions>();
  CLI::App* run = cmd->add_subcommand(
      "run",
      "Camera images to labelled 3D markers and the skeleton: blobs, epipolar matching, "
      "triangulation, T-pose labelling, tracking, gap filling, marker IK");
  add_run_options(run, r.get());
  auto b = std::make_shared<CaptureBenchOptions>();
  CLI::App* bench = cmd->add_subcommand(
      "bench",
      "How fast a recorded capture is processed: its frames loaded into memory first, then "
      "blobs, matching, triangulation and labelling timed (the real-time figure)");
  bench->add_option("dir", b->dir, "recorded capture folder")->required();
  bench->add_option("--rig", b->rig_path, "camera rig JSON (default as capture run)");
  bench->add_option("--frames", b->frames, "frames to load and time")->capture_default_str();
  bench->add_option("--threads", b->threads, "threads for the cameras' images (0: every core)")
      ->capture_default_str();
  bench->add_flag("!--no-label", b->label, "time the 3D points only");
  bench->add_flag("!--no-2d-tracks", b->tracking_2d, "no 2D blob tracks (as capture run)");
  b->subject.subject.add_to(bench, false);
  bench->add_option("--summary", b->summary_path, "JSON of the figures");
  auto k = std::make_shared<CalibrateOptions>();
  CLI::App* calibrate = cmd->add_subcommand(
      "calibrate",
      "The rig from DIR/calibration: a wand wave (poses, lenses, bundle adjustment) and "
      "an L-frame (the lab frame); writes DIR/rig.json");
  calibrate->add_option("dir", k->dir, "capture folder with calibration/wand, calibration/lframe")
      ->required();
  calibrate->add_option("--nominal", k->nominal_path,
                        "rig JSON with each camera's image size and lens guess (default: "
                        "DIR/calibration/nominal.json)");
  calibrate->add_option("--wand-ab", k->wand.ab_m, "wand: A to B, m")->capture_default_str();
  calibrate->add_option("--wand-ac", k->wand.ac_m, "wand: A to C, m")->capture_default_str();
  calibrate->add_option("-o,--output", k->output, "rig JSON to write (default: DIR/rig.json)");
  calibrate
      ->add_option("--intrinsics", k->intrinsics,
                   "lenses from: checkerboard (DIR/calibration/checkerboard/<camera>/*.png), "
                   "nominal (the nominal rig's), auto (checkerboard when its folder is there)")
      ->capture_default_str();
  calibrate->add_option("--board", k->board, "checkerboard inner corners COLSxROWS")
      ->capture_default_str();
  calibrate->add_option("--square-mm", k->square_mm, "checkerboard square side, mm")
      ->capture_default_str();
  return {cmd, [s, synth, r, run, k, calibrate, b, bench]() {
            if (synth->parsed()) return run_synth(*s);
            if (bench->parsed()) return run_capture_bench(*b);
            if (calibrate->parsed()) return run_calibrate(*k);
            if (run->parsed()) return run_capture(*r);
            return kExitBadInput;
          }};
#else
  cmd->allow_extras();
  return {cmd, []() -> int {
            throw sim::InvalidArgument(
                "this biodyn was built without optical capture (OpenCV 4 missing: apt-get "
                "install libopencv-dev libceres-dev, then rebuild)");
          }};
#endif
}

}  // namespace biodyn::apps
