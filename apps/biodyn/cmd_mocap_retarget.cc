// biodyn mocap retarget: a BVH motion on a generated character (issue 5; retarget.h).
#include "cmd_mocap_retarget.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <iostream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/mocap_io/retarget.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "cmd_mocap.h"

namespace biodyn::apps {
namespace {

using nlohmann::json;

/// The map given (a built-in name or a JSON file), else the first built-in map whose joints
/// the BVH has.
mocap_io::JointMap choose_map(const std::string& given, const mocap_io::BvhMotion& bvh,
                              const std::string& bvh_path) {
  if (given.find(".json") != std::string::npos) return mocap_io::read_joint_map(given);
  if (!given.empty()) return mocap_io::builtin_joint_map(given);
  std::string tried;
  if (auto map = mocap_io::first_fitting_builtin_map(bvh, bvh_path, &tried)) return *map;
  throw sim::InvalidArgument(bvh_path +
                             ": no built-in joint map fits this BVH; give --map "
                             "FILE.json (see mocap_io/README.md, \"Retargeting\"). Tried:" +
                             tried);
}

/// Lowest sole point of each foot per frame (m; NaN for unsolved frames), from MuJoCo's
/// kinematics of the output.
std::array<std::vector<double>, 2> sole_heights(const mocap_io::RetargetResult& r) {
  const models::Character c = models::generate_character(r.spec);
  const sim::Model model = sim::Model::from_string(models::to_mjcf(c), "retargeted character");
  sim::Data data(*model);
  std::array<std::vector<int>, 2> sites;
  for (int i = 0; i < model->nsite; ++i) {
    const char* name = mj_id2name(model.get(), mjOBJ_SITE, i);
    const std::string n = name ? name : "";
    if (n.rfind("marker_sole_", 0) != 0) continue;
    sites[n.back() == 'l' ? 0 : 1].push_back(i);
  }
  std::array<std::vector<double>, 2> out;
  for (int f = 0; f < r.motion.frame_count(); ++f) {
    const bool solved = r.motion.qpos.row(f).allFinite();
    if (solved) {
      for (int k = 0; k < model->nq; ++k) data->qpos[k] = r.motion.qpos(f, k);
      mj_kinematics(model.get(), data.get());
    }
    for (int s = 0; s < 2; ++s) {
      double low = std::numeric_limits<double>::quiet_NaN();
      if (solved) {
        low = std::numeric_limits<double>::infinity();
        for (int site : sites[static_cast<size_t>(s)])
          low = std::min(low, data->site_xpos[3 * site + 2]);
      }
      out[static_cast<size_t>(s)].push_back(low);
    }
  }
  return out;
}

/// feet.png: the feet's lowest sole points over time with the stances shaded, and each
/// stance's slide against the 1 cm bound.
void plot_feet(const std::string& dir, const mocap_io::RetargetResult& r) {
  const auto heights = sole_heights(r);
  std::ostringstream data;
  data.precision(6);
  for (int f = 0; f < r.motion.frame_count(); ++f) {
    data << r.motion.times_s[static_cast<size_t>(f)] << " "
         << 1000 * heights[0][static_cast<size_t>(f)] << " "
         << 1000 * heights[1][static_cast<size_t>(f)] << "\n";
  }
  data << "\n\n";
  for (size_t i = 0; i < r.steps.size(); ++i) {
    const mocap_io::StanceStep& s = r.steps[i];
    data << i + 1 << " " << 1000 * s.slide_m << " " << (s.side == 'l' ? 0 : 1) << "\n";
  }
  write_file_atomically(dir + "/feet_plot.dat", data.str());
  const double dt = r.motion.frame_count() > 1 ? r.motion.times_s[1] - r.motion.times_s[0] : 0.0;
  std::ostringstream gp;
  gp << "set terminal pngcairo size 1400,800 font 'sans,10'\n"
     << "set output '" << dir << "/feet.png.tmp'\n"
     << "set multiplot layout 2,1 title 'Retargeted feet: " << r.spec.height_m << " m body, scale "
     << r.stats.scale << "'\n"
     << "set grid\nset title 'Lowest sole point of each foot (shaded: stances detected on the "
        "capture; left blue, right red)'\n"
     << "set xlabel 'time (s)'\nset ylabel 'height above the floor (mm)'\n"
     << "set style rect fc lt -1 fs solid 0.08 noborder\n";
  int obj = 1;
  for (const mocap_io::StanceStep& s : r.steps) {
    gp << "set object " << obj++ << " rect from " << s.first_frame * dt << ", graph 0 to "
       << s.last_frame * dt << ", graph 1 fc rgb '" << (s.side == 'l' ? "#3060c0" : "#c03030")
       << "' fs solid " << (s.side == 'l' ? 0.08 : 0.12) << " noborder behind\n";
  }
  gp << "plot '" << dir
     << "/feet_plot.dat' index 0 using 1:2 with lines lw 1.5 lc rgb '#3060c0' "
        "title 'left', '' index 0 using 1:3 with lines lw 1.5 lc rgb '#c03030' title 'right', "
        "-"
     << 1000 * mocap_io::kRetargetPenetrationBound_m
     << " with lines dt 2 lc rgb 'black' title 'penetration bound ("
     << 1000 * mocap_io::kRetargetPenetrationBound_m << " mm)'\n"
     << "unset object\n"
     << "set title 'Stance-foot slide per step (largest horizontal travel of a planted sole "
        "point)'\n"
     << "set xlabel 'step (in order of touch-down)'\nset ylabel 'slide (mm)'\n"
     << "set style fill solid 0.7\nset boxwidth 0.7\nset xrange [0:" << r.steps.size() + 1 << "]\n"
     << "plot '" << dir
     << "/feet_plot.dat' index 1 using 1:($3==0?$2:1/0) with boxes lc rgb "
        "'#3060c0' title 'left', '' index 1 using 1:($3==1?$2:1/0) with boxes lc rgb '#c03030' "
        "title 'right', 10 with lines dt 2 lc rgb 'black' title '1 cm'\n"
     << "unset multiplot\n";
  write_file_atomically(dir + "/feet.gp", gp.str());
  plot_with_gnuplot("mocap retarget", dir + "/feet.gp", dir + "/feet.png.tmp", dir + "/feet.png");
}

/// m: the slide bound a step is counted against ("steps under 1 cm").
constexpr double kSlideBound_m = 0.01;

/// The retargeting options from the command line: units from --metres-per-unit and --up over
/// the map's. Throws sim::InvalidArgument for a bad value.
mocap_io::RetargetOptions retarget_options(const RetargetCliOptions& o,
                                           const mocap_io::JointMap& map) {
  mocap_io::RetargetOptions options;
  options.source = o.input();
  options.align_start = o.align_start;
  if (o.metres_per_unit || !o.up.empty()) {
    mocap_io::BvhUnits units = map.units.value_or(mocap_io::BvhUnits{});
    if (o.metres_per_unit) {
      if (!(*o.metres_per_unit > 0 && std::isfinite(*o.metres_per_unit))) {
        throw sim::InvalidArgument("--metres-per-unit: must be a finite number > 0, got " +
                                   std::to_string(*o.metres_per_unit));
      }
      units.metres_per_unit = *o.metres_per_unit;
    }
    if (!o.up.empty()) {
      if (o.up != "y" && o.up != "z") {
        throw sim::InvalidArgument("--up: expected y or z, got '" + o.up + "'");
      }
      units.up = o.up == "y" ? mocap_io::UpAxis::kY : mocap_io::UpAxis::kZ;
    }
    options.units = units;
  }
  return options;
}

/// Steps whose slide is under kSlideBound_m.
int steps_under_bound(const std::vector<mocap_io::StanceStep>& steps) {
  int under = 0;
  for (const mocap_io::StanceStep& step : steps) under += step.slide_m < kSlideBound_m ? 1 : 0;
  return under;
}

/// stats.json: the run's inputs, the statistics measured on the output, the assumptions, and
/// every stance step and contact.
json retarget_stats(const RetargetCliOptions& o, const mocap_io::JointMap& map,
                    const mocap_io::RetargetOptions& options, const models::CharacterSpec& spec,
                    const mocap_io::RetargetResult& r) {
  const mocap_io::RetargetStats& s = r.stats;
  json steps = json::array();
  for (const mocap_io::StanceStep& step : r.steps) {
    steps.push_back({{"side", std::string(1, step.side)},
                     {"first_frame", step.first_frame},
                     {"last_frame", step.last_frame},
                     {"slide_m", step.slide_m},
                     {"slide_frame", step.slide_frame},
                     {"height_error_m", step.height_error_m},
                     {"joints_at_limit", step.joints_at_limit}});
  }
  json contacts = json::array();
  for (const mocap_io::FootContact& c : r.contacts) {
    contacts.push_back({{"side", std::string(1, c.side)},
                        {"point", c.point},
                        {"first_frame", c.first_frame},
                        {"last_frame", c.last_frame}});
  }
  const mocap_io::BvhUnits units = options.units.value_or(map.units.value_or(mocap_io::BvhUnits{}));
  return {
      {"bvh", o.bvh},
      {"motion", o.motion},
      {"joint_map", map.name},
      {"bvh_units",
       {{"metres_per_unit", units.metres_per_unit},
        {"up", units.up == mocap_io::UpAxis::kY ? "y" : "z"}}},
      {"character", character_json(spec)},
      {"frames", s.frames},
      {"unsolved_frames", s.unsolved_frames},
      {"scale", s.scale},
      {"bvh_leg_m", s.bvh_leg_m},
      {"character_leg_m", s.character_leg_m},
      {"keypoint_rms_m", s.keypoint_rms_m},
      {"keypoint_max_m", s.keypoint_max_m},
      {"keypoint_max", {{"keypoint", s.keypoint_max_name}, {"frame", s.keypoint_max_frame}}},
      {"max_slide_m", s.max_slide_m},
      {"steps_under_1cm", steps_under_bound(r.steps)},
      {"max_penetration_m", s.max_penetration_m},
      {"penetration", {{"frame", s.penetration_frame}, {"geom", s.penetration_geom}}},
      {"bvh_travel_m", s.bvh_travel_m},
      {"character_travel_m", s.character_travel_m},
      {"released_contacts", s.released_contacts},
      {"mean_ik_iterations", s.mean_ik_iterations},
      {"frames_per_second", s.frames / std::max(s.total_seconds, 1e-9)},
      {"assumptions",
       {"kinematic: joint angles only, no dynamics (run mocap id on motion.csv for the forces "
        "the motion needs)",
        "foot contacts are detected on the capture (heights and speeds of heel and ball) and the "
        "character's sole points are pinned to the floor (z = 0) where they land",
        "a planted point the character's joint ranges cannot hold is released (the heel or toes "
        "lift early) or slides: such steps list the leg's joints at their limits"}},
      {"steps", steps},
      {"contacts", contacts}};
}

/// The console summary: scale, slides, penetration and keypoint error, then each step sliding
/// beyond the bound with the joints at their limits.
void print_retarget(const RetargetCliOptions& o, const mocap_io::JointMap& map,
                    const models::CharacterSpec& spec, const mocap_io::RetargetResult& r) {
  const mocap_io::RetargetStats& s = r.stats;
  std::cout << "mocap retarget: " << s.frames << " frames of " << o.input() << " (map " << map.name
            << ") on a " << spec.height_m << " m body, scale " << s.scale << " (leg "
            << s.character_leg_m << " m / " << s.bvh_leg_m << " m)\n"
            << "  stance-foot slide: " << steps_under_bound(r.steps) << " of " << r.steps.size()
            << " steps under 1 cm, max " << 1000 * s.max_slide_m << " mm; ground penetration max "
            << 1000 * s.max_penetration_m << " mm; keypoint RMS " << 1000 * s.keypoint_rms_m
            << " mm; " << s.unsolved_frames << " unsolved frames\n";
  for (const mocap_io::StanceStep& step : r.steps) {
    if (step.slide_m < kSlideBound_m) continue;
    std::string limits;
    for (const std::string& j : step.joints_at_limit) limits += " " + j;
    std::cout << "  step " << step.side << " frames " << step.first_frame << "-" << step.last_frame
              << " slides " << 1000 * step.slide_m << " mm"
              << (limits.empty() ? "" : " (at limit:" + limits + ")") << "\n";
  }
  std::cout << "  assumption: kinematic retarget; stance feet pinned where the capture's "
               "contacts land (stats.json \"assumptions\")\n"
            << "wrote " << o.output << "/{motion.csv, character.bvh, stats.json, feet.png}\n";
}

}  // namespace

void RetargetCliOptions::add_to(CLI::App* cmd) {
  CLI::Option* bvh_option = cmd->add_option("--bvh", bvh, "BVH motion to retarget");
  cmd->add_option("--motion", motion,
                  "or a qpos CSV with its body (mocap ik, retarget): onto another body, or onto "
                  "its own (no body options) with its stance feet planted flat and still, e.g. "
                  "a marker-IK walk before mocap track")
      ->excludes(bvh_option);
  character.add_to(cmd);
  cmd->add_option(
      "--map", map, "joint map: a built-in name (" + [] {
        std::string names;
        for (const std::string& n : mocap_io::builtin_joint_map_names()) {
          names += (names.empty() ? "" : ", ") + n;
        }
        return names;
      }() + ") or a JSON file; default: the first built-in map the BVH fits");
  cmd->add_option("--metres-per-unit", metres_per_unit,
                  "BVH length unit in metres (default: the map's, e.g. CMU 0.056444; else 0.01)");
  cmd->add_option("--up", up, "BVH vertical axis: y or z (default: the map's, else y)");
  cmd->add_flag("--align-start", align_start,
                "start at the origin facing +x (default: keep the capture's position and heading)");
  cmd->add_option("-o,--output", output,
                  "output directory: motion.csv, character.bvh, stats.json, feet.png")
      ->required();
}

int run_retarget(const RetargetCliOptions& o) {
  if (o.bvh.empty() == o.motion.empty())
    throw sim::InvalidArgument("give the motion to retarget: --bvh FILE or --motion FILE.csv");
  if (!o.motion.empty() && (o.metres_per_unit || !o.up.empty()))
    throw sim::InvalidArgument(
        "--metres-per-unit and --up describe a BVH file; a qpos CSV (--motion) is in metres, z "
        "up");
  check_outputs({{"-o", o.output, true}}, {o.input(), o.map, o.character.body_path});
  std::vector<std::string> notes;
  mocap_io::BvhMotion bvh;
  models::CharacterSpec spec;
  if (!o.bvh.empty()) {
    bvh = mocap_io::read_bvh(o.bvh);
    spec = o.character.to_spec();
  } else {
    // The motion's own body unless another is given: planted feet on the same body.
    bvh = mocap_io::motion_bvh(mocap_io::read_motion_csv(o.motion), o.motion);
    spec = o.character.geometry_given() ? o.character.to_spec()
                                        : o.character.spec_for_motion(o.motion, &notes);
  }
  for (const std::string& n : notes) std::cout << "note: " << n << "\n";
  const mocap_io::JointMap map = choose_map(o.map, bvh, o.input());
  const mocap_io::RetargetOptions options = retarget_options(o, map);
  ProgressBar bar("mocap retarget: " + std::to_string(bvh.frame_count()) + " frames");
  const mocap_io::RetargetResult r =
      mocap_io::retarget_bvh(bvh, map, spec, options, [&](double f) { bar.update(f); });
  bar.finish();
  // Every output's text first, then the plot (gnuplot may fail), then the files: a failure
  // leaves none of motion.csv, character.bvh, stats.json.
  const std::string motion_text = mocap_io::format_motion_csv(r.motion);
  const std::string bvh_text = mocap_io::format_bvh(r.bvh);
  const std::string stats_text = json_text(retarget_stats(o, map, options, spec, r), 1) + "\n";
  plot_feet(o.output, r);
  write_file_atomically(o.output + "/motion.csv", motion_text);
  write_file_atomically(o.output + "/character.bvh", bvh_text);
  write_file_atomically(o.output + "/stats.json", stats_text);
  print_retarget(o, map, spec, r);
  return kExitOk;
}

Command add_mocap_retarget_command(CLI::App* mocap) {
  auto rt = std::make_shared<RetargetCliOptions>();
  CLI::App* rt_cmd =
      mocap->add_subcommand("retarget",
                            "A BVH motion (or a qpos CSV with its body) on a generated character: "
                            "qpos CSV, the character's BVH, foot-slide and penetration stats");
  rt->add_to(rt_cmd);
  return {rt_cmd, [rt]() { return run_retarget(*rt); }};
}

}  // namespace biodyn::apps
