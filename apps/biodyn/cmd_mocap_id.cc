// biodyn mocap id: inverse dynamics of a motion (qpos CSV from mocap ik or retarget) on a
// generated character: joint torques, root residuals and ground forces (issue 5;
// inverse_dynamics.h).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "biodyn/mocap_io/bvh.h"
#include "biodyn/mocap_io/c3d.h"
#include "biodyn/mocap_io/inverse_dynamics.h"
#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "cli_common.h"
#include "cmd_mocap.h"

namespace biodyn::apps {
namespace {

using nlohmann::json;

struct IdOptions {
  std::string motion, output;
  IdSettings settings;
  CharacterOptions character;
};

/// Rotates force plates into biodyn's world (z up) when the lab's vertical is y.
void to_z_up(std::vector<mocap_io::ForcePlate>* plates, const std::string& lab_up) {
  if (lab_up == "z") return;
  const Eigen::Matrix3d r = mocap_io::file_to_world(mocap_io::UpAxis::kY);
  for (mocap_io::ForcePlate& p : *plates) {
    p.corners_m = r * p.corners_m;
    for (Eigen::MatrixXd* m : {&p.force_N, &p.moment_origin_Nm, &p.cop_m, &p.free_moment_Nm}) {
      *m = *m * r.transpose();  // rows are vectors: v' R'
    }
  }
}

/// Heel strikes of one foot: times its body origin comes down to within kStrikeHeight_m of its
/// lowest height in the motion after being higher than kLiftHeight_m above it.
std::vector<double> foot_strikes(const mjModel& m, const mocap_io::Motion& motion, int body) {
  constexpr double kStrikeHeight_m = 0.02;  // a planted foot is within 2 cm of its lowest
  constexpr double kLiftHeight_m = 0.05;    // swing lifts the ankle by more than 5 cm
  if (body < 0) return {};
  sim::Data d(m);
  std::vector<double> z(static_cast<size_t>(motion.frame_count()));
  for (int f = 0; f < motion.frame_count(); ++f) {
    for (int k = 0; k < m.nq; ++k) d->qpos[k] = motion.qpos(f, k);
    mj_kinematics(&m, d.get());
    z[static_cast<size_t>(f)] = d->xpos[3 * body + 2];
  }
  const double lowest = *std::min_element(z.begin(), z.end());
  std::vector<double> strikes;
  bool lifted = false;
  for (size_t f = 0; f < z.size(); ++f) {
    if (z[f] > lowest + kLiftHeight_m) lifted = true;
    if (lifted && z[f] < lowest + kStrikeHeight_m) {
      strikes.push_back(motion.times_s[f]);
      lifted = false;
    }
  }
  return strikes;
}

/// gnuplot script and data plotting the sagittal torques of hip, knee and ankle over the gait
/// cycle (left heel strike to left heel strike; over time when there is no full cycle).
void plot_torques(const std::string& dir, const mocap_io::InverseDynamicsResult& id,
                  const std::vector<double>& strikes, double mass_kg) {
  const std::vector<std::pair<std::string, std::string>> panels = {
      {"hip_l_y", "hip flexion-extension (left, about y)"},
      {"knee_flexion_l", "knee flexion (left)"},
      {"ankle_dorsiflexion_l", "ankle dorsiflexion (left)"},
      {"hip_r_y", "hip flexion-extension (right, about y)"},
      {"knee_flexion_r", "knee flexion (right)"},
      {"ankle_dorsiflexion_r", "ankle dorsiflexion (right)"}};
  const bool cycles = strikes.size() >= 2;
  std::ostringstream data;
  data.precision(6);
  for (const auto& [dof, title] : panels) {
    const auto it = std::find(id.dof_names.begin(), id.dof_names.end(), dof);
    data << "# " << dof << "\n";
    if (it != id.dof_names.end()) {
      const Eigen::Index col = it - id.dof_names.begin();
      for (size_t i = 0; i < id.times_s.size(); ++i) {
        const double t = id.times_s[i];
        double x = t;
        if (cycles) {
          const auto next = std::upper_bound(strikes.begin(), strikes.end(), t);
          if (next == strikes.begin() || next == strikes.end()) continue;
          const double t0 = *(next - 1), t1 = *next;
          x = 100.0 * (t - t0) / (t1 - t0);
          if (i > 0 && id.times_s[i - 1] < t0) data << "\n";  // a new cycle: a new line
        }
        data << x << " " << id.generalized_force(static_cast<Eigen::Index>(i), col) / mass_kg
             << "\n";
      }
    }
    data << "\n\n";
  }
  write_file_atomically(dir + "/torques_plot.dat", data.str());
  std::ostringstream gp;
  gp << "set terminal pngcairo size 1400,800 font 'sans,10'\n"
     << "set output '" << dir << "/torques.png.tmp'\n"
     << "set multiplot layout 2,3 title 'Joint torques per kg of body mass (" << mass_kg
     << " kg)'\n"
     << "set grid\nset xlabel '"
     << (cycles ? "% of the gait cycle (left heel strike to left heel strike)" : "time (s)")
     << "'\nset ylabel 'N m / kg'\n";
  for (size_t p = 0; p < panels.size(); ++p) {
    gp << "set title '" << panels[p].second << "'\n"
       << "plot '" << dir << "/torques_plot.dat' index " << p << " with lines lw 1.5 notitle\n";
  }
  gp << "unset multiplot\n";
  write_file_atomically(dir + "/torques.gp", gp.str());
  plot_with_gnuplot("mocap id", dir + "/torques.gp", dir + "/torques.png.tmp",
                    dir + "/torques.png");
}

/// torques.csv: time and the generalised force of every DOF, per frame.
std::string torques_csv(const mocap_io::InverseDynamicsResult& id) {
  std::ostringstream torques;
  torques.precision(9);
  torques << "time";
  for (const std::string& n : id.dof_names) torques << "," << n;
  torques << "\n";
  for (size_t i = 0; i < id.times_s.size(); ++i) {
    const Eigen::Index r = static_cast<Eigen::Index>(i);
    torques << id.times_s[i];
    for (Eigen::Index c = 0; c < id.generalized_force.cols(); ++c) {
      torques << "," << id.generalized_force(r, c);
    }
    torques << "\n";
  }
  return torques.str();
}

/// residuals.csv: time, the root's residual force and moment and the ground force, per frame.
std::string residuals_csv(const mocap_io::InverseDynamicsResult& id) {
  std::ostringstream residuals;
  residuals.precision(9);
  residuals << "time,residual_fx,residual_fy,residual_fz,residual_mx,residual_my,"
               "residual_mz,ground_fx,ground_fy,ground_fz\n";
  for (size_t i = 0; i < id.times_s.size(); ++i) {
    const Eigen::Index r = static_cast<Eigen::Index>(i);
    residuals << id.times_s[i];
    for (int k = 0; k < 3; ++k) residuals << "," << id.residual_force_N(r, k);
    for (int k = 0; k < 3; ++k) residuals << "," << id.residual_moment_Nm(r, k);
    for (int k = 0; k < 3; ++k) residuals << "," << id.ground_force_N(r, k);
    residuals << "\n";
  }
  return residuals.str();
}

/// The name of an InverseDynamicsResult::plate_foot entry.
const char* plate_foot_name(int foot) {
  switch (foot) {
    case models::kLeft:
      return "left";
    case models::kRight:
      return "right";
    case mocap_io::kPlateUnassigned:
      return "unassigned";
    default:
      return "unloaded";
  }
}

/// plates.csv: time and, per plate, the foot that carried its load.
std::string plates_csv(const mocap_io::InverseDynamicsResult& id) {
  std::ostringstream out;
  out.precision(9);
  out << "time";
  for (Eigen::Index p = 0; p < id.plate_foot.cols(); ++p) out << ",plate" << p + 1 << "_foot";
  out << "\n";
  for (size_t i = 0; i < id.times_s.size(); ++i) {
    out << id.times_s[i];
    for (Eigen::Index p = 0; p < id.plate_foot.cols(); ++p) {
      out << "," << plate_foot_name(id.plate_foot(static_cast<Eigen::Index>(i), p));
    }
    out << "\n";
  }
  return out.str();
}

/// Per plate: frames loaded by each foot and unassigned (with the times), for summary.json.
json plate_summary(const mocap_io::InverseDynamicsResult& id, int* unassigned_total) {
  json plates = json::array();
  *unassigned_total = 0;
  for (Eigen::Index p = 0; p < id.plate_foot.cols(); ++p) {
    int left = 0, right = 0, unassigned = 0;
    std::vector<double> unassigned_times;
    for (Eigen::Index i = 0; i < id.plate_foot.rows(); ++i) {
      const int foot = id.plate_foot(i, p);
      left += foot == models::kLeft;
      right += foot == models::kRight;
      if (foot == mocap_io::kPlateUnassigned) {
        ++unassigned;
        unassigned_times.push_back(id.times_s[static_cast<size_t>(i)]);
      }
    }
    *unassigned_total += unassigned;
    plates.push_back({{"plate", p + 1},
                      {"frames_left_foot", left},
                      {"frames_right_foot", right},
                      {"frames_unassigned", unassigned},
                      {"unassigned_times_s", unassigned_times}});
  }
  return plates;
}

/// Per frame, the norm of each row of `x` (N or N m).
Eigen::VectorXd row_norms(const Eigen::MatrixXd& x) { return x.rowwise().norm(); }

/// What the ground forces of --grf `grf` rest on, for the summary.
std::string ground_caveat(const std::string& grf) {
  if (grf == "none") return "no ground force: the root residual is the whole ground reaction";
  if (is_estimate(grf)) {
    return "estimated from the kinematics (sole points within 4 cm of the floor and under "
           "0.8 m/s, friction pyramid mu 0.5, least root residual and leg torques; Fluit 2014, "
           "Skals 2017): assumes a flat, level floor and that the body's mass is the subject's";
  }
  return "measured force plates";
}

/// summary.json: what was run on what, the residuals' peaks and RMS, the heel strikes and each
/// DOF's peak torque.
json id_summary(const IdOptions& o, const mocap_io::InverseDynamicsResult& id, int first_used,
                const models::CharacterSpec& spec, double body_weight_N,
                const std::vector<double>& strikes) {
  const Eigen::VectorXd fn = row_norms(id.residual_force_N), mn = row_norms(id.residual_moment_Nm);
  json peaks = json::object();
  for (size_t c = 0; c < id.dof_names.size(); ++c) {
    peaks[id.dof_names[c]] =
        id.generalized_force.col(static_cast<Eigen::Index>(c)).cwiseAbs().maxCoeff();
  }
  return {{"motion", o.motion},
          {"frames_used", id.times_s.size()},
          {"first_frame_used", first_used},
          {"time_span_s", {id.times_s.front(), id.times_s.back()}},
          {"character", character_json(spec)},
          {"ground", o.settings.grf},
          {"ground_caveat", ground_caveat(o.settings.grf)},
          {"filter",
           {{"type", "Butterworth 2nd order, forward-backward (zero lag)"},
            {"cutoff_hz", o.settings.cutoff_hz}}},
          {"armature_and_damping", "left out (simulation stabilisers, not body properties)"},
          {"residual_force_peak_N", fn.maxCoeff()},
          {"residual_force_rms_N", std::sqrt(fn.squaredNorm() / static_cast<double>(fn.size()))},
          {"residual_moment_peak_Nm", mn.maxCoeff()},
          {"residual_moment_rms_Nm", std::sqrt(mn.squaredNorm() / static_cast<double>(mn.size()))},
          {"body_weight_N", body_weight_N},
          {"left_heel_strikes_s", strikes},
          {"peak_torques", peaks}};
}

/// ground.csv (--grf estimate): per frame, each foot's estimated force, centre of pressure and
/// vertical free moment.
std::string ground_csv(const mocap_io::InverseDynamicsResult& id) {
  const mocap_io::GroundForceEstimate& e = id.ground_estimate;
  std::ostringstream out;
  out << "time";
  for (const char* side : {"l", "r"}) {
    for (const char* c : {"fx", "fy", "fz", "cop_x", "cop_y", "cop_z", "free_moment_z"}) {
      out << "," << c << "_" << side;
    }
  }
  out << "\n";
  out.precision(9);
  for (size_t f = 0; f < id.times_s.size(); ++f) {
    const auto i = static_cast<Eigen::Index>(f);
    out << id.times_s[f];
    for (size_t side = 0; side < 2; ++side) {
      for (int c = 0; c < 3; ++c) out << "," << e.force_N[side](i, c);
      for (int c = 0; c < 3; ++c) {
        const double v = e.cop_m[side](i, c);
        out << ",";
        if (std::isfinite(v)) out << v;  // empty: no load, no centre of pressure
      }
      out << "," << e.free_moment_Nm[side](i);
    }
    out << "\n";
  }
  return out.str();
}

/// summary.json's "ground_estimate_check": the estimate against the capture's plates.
json plate_check_json(const mocap_io::PlateComparison& c, double mass_kg) {
  if (c.frames == 0) {
    return {{"frames", 0},
            {"note", "no frame where a plate sees one whole foot of this motion: not checked"}};
  }
  const double bw = c.body_weight_N;
  json j = {
      {"frames", c.frames},
      {"frames_rule", "a plate is loaded, its load is one foot's and it sees that whole foot"},
      {"vertical_rms_N", c.vertical_rms_N},
      {"vertical_rms_percent_bw", 100 * c.vertical_rms_N / bw},
      {"fore_aft_rms_N", c.fore_aft_rms_N},
      {"fore_aft_rms_percent_bw", 100 * c.fore_aft_rms_N / bw},
      {"lateral_rms_N", c.lateral_rms_N},
      {"lateral_rms_percent_bw", 100 * c.lateral_rms_N / bw},
      {"vertical_peak_error_N", c.vertical_peak_error_N},
      {"single_support_frames", c.single_support_frames}};
  if (std::isfinite(c.single_support_ratio)) {
    j["single_support_plate_over_estimate"] = c.single_support_ratio;
    j["mass_the_plates_suggest_kg"] = c.single_support_ratio * mass_kg;
  }
  return j;
}

/// ground_check.csv: per compared frame, the foot and its estimated and measured force.
std::string plate_check_csv(const mocap_io::PlateComparison& c) {
  std::ostringstream out;
  out << "time,foot,estimated_fx,estimated_fy,estimated_fz,plate_fx,plate_fy,plate_fz\n";
  out.precision(9);
  for (size_t i = 0; i < c.times_s.size(); ++i) {
    out << c.times_s[i] << "," << (c.sides[i] == models::kLeft ? "left" : "right");
    for (int k = 0; k < 3; ++k) out << "," << c.estimated_N[i](k);
    for (int k = 0; k < 3; ++k) out << "," << c.measured_N[i](k);
    out << "\n";
  }
  return out.str();
}

/// The console lines of the plate check; a WARNING when the plates suggest another mass.
void print_plate_check(const mocap_io::PlateComparison& c, double mass_kg) {
  const double bw = c.body_weight_N;
  if (c.frames == 0) {
    std::cerr << "WARNING: no frame where a plate sees one whole foot of this motion: the "
                 "estimate is not checked (is the motion from this capture, in its lab frame?)\n";
    return;
  }
  std::cout << "  estimate vs plates over " << c.frames << " frames (a plate sees one whole "
            << "foot): vertical RMS " << c.vertical_rms_N << " N (" << 100 * c.vertical_rms_N / bw
            << "% BW), fore-aft " << c.fore_aft_rms_N << " N (" << 100 * c.fore_aft_rms_N / bw
            << "% BW), lateral " << c.lateral_rms_N << " N (" << 100 * c.lateral_rms_N / bw
            << "% BW); per frame in ground_check.csv\n";
  if (std::isfinite(c.single_support_ratio) && std::abs(c.single_support_ratio - 1) > 0.05) {
    std::cerr << "WARNING: in single support the plates measure " << c.single_support_ratio
              << " of the estimate's vertical force: the subject may weigh about "
              << c.single_support_ratio * mass_kg << " kg, not " << mass_kg
              << " kg (give --mass; the estimate scales with it)\n";
  }
}

/// The console summary: residual peaks against the body weight, and what the ground model means.
void print_id(const IdOptions& o, const mocap_io::InverseDynamicsResult& id,
              mocap_io::GroundForces ground, const models::CharacterSpec& spec,
              double body_weight_N) {
  const Eigen::VectorXd fn = row_norms(id.residual_force_N), mn = row_norms(id.residual_moment_Nm);
  std::cout << "mocap id: " << id.times_s.size() << " frames on " << spec.height_m << " m / "
            << spec.mass_kg << " kg, ground " << o.settings.grf << ": residual force peak "
            << fn.maxCoeff() << " N (body weight " << body_weight_N << " N), moment peak "
            << mn.maxCoeff() << " N m\n";
  if (ground == mocap_io::GroundForces::kNone) {
    std::cout << "  --grf none: the residual is the whole ground reaction the motion "
                 "needs, not a modelling error\n";
  }
  if (ground == mocap_io::GroundForces::kEstimated) {
    const Eigen::VectorXd fz = id.ground_force_N.col(2);
    std::cout << "  --grf estimate: ground forces from the kinematics (peak vertical "
              << fz.maxCoeff() / body_weight_N
              << " body weights); assumes a flat floor and the subject's mass\n";
  }
  std::cout << "wrote " << o.output << "/{torques.csv, residuals.csv, "
            << (ground == mocap_io::GroundForces::kForcePlates ? "plates.csv, " : "")
            << (ground == mocap_io::GroundForces::kEstimated ? "ground.csv, " : "")
            << "summary.json, torques.png}\n";
}

int run_id(const IdOptions& o) {
  check_outputs({{"-o", o.output, true}}, {o.motion, o.settings.c3d});
  const IdGround ground = id_ground(o.settings);
  const mocap_io::Motion all = mocap_io::read_motion_csv(o.motion);
  std::vector<std::string> notes;
  const models::CharacterSpec spec = o.character.spec_for_motion(o.motion, &notes);
  const models::Character character = models::generate_character(spec);
  const sim::Model model = sim::Model::from_string(models::to_mjcf(character), "character");
  mocap_io::check_motion_matches(all, *model, o.motion);
  const MotionId run = run_motion_id(*model, all, o.settings, ground, "mocap id", &notes);
  const mocap_io::InverseDynamicsResult& id = run.id;
  const std::vector<double> strikes =
      foot_strikes(*model, run.motion, models::Rig(*model).leg(models::kLeft).foot);
  const double body_weight_N = character.total_mass_kg() * 9.81;
  json summary = id_summary(o, id, run.first_frame + run.trim_frames, spec, body_weight_N, strikes);
  summary["notes"] = notes;
  summary["body_source"] =
      mocap_io::motion_body(all, o.motion) ? "the motion's header" : "the command line";
  int unassigned = 0;
  const bool plates_used = ground.ground == mocap_io::GroundForces::kForcePlates;
  if (plates_used) {
    summary["plates"] = plate_summary(id, &unassigned);
    summary["plate_assignment"] =
        "a plate's load goes to the foot whose sole is on the plate (within 3 cm of its surface) "
        "with the centre of pressure under it (within 4 cm), applied at the centre of pressure to "
        "the foot, or to its toes when the force's line would turn them up about their joint "
        "(push-off); unassigned loads (both feet or neither) are not applied and stay in the root "
        "residual";
  }
  const bool estimated = ground.ground == mocap_io::GroundForces::kEstimated;
  std::optional<mocap_io::PlateComparison> check;
  if (estimated && !ground.plates.empty()) {
    check = mocap_io::compare_with_plates(*model, id, ground.plates, ground.plate_rate_hz);
    summary["ground_estimate_check"] = plate_check_json(*check, character.total_mass_kg());
  }
  // Every output's text first, then the plot (gnuplot may fail), then the files: a failure
  // leaves none of torques.csv, residuals.csv, plates.csv, ground.csv, summary.json.
  const std::string torques = torques_csv(id), residuals = residuals_csv(id);
  const std::string plates_text = plates_used ? plates_csv(id) : std::string();
  const std::string ground_text = estimated ? ground_csv(id) : std::string();
  const std::string check_text = check ? plate_check_csv(*check) : std::string();
  const std::string summary_text = json_text(summary, 1) + "\n";
  std::filesystem::create_directories(o.output);
  plot_torques(o.output, id, strikes, spec.mass_kg);
  write_file_atomically(o.output + "/torques.csv", torques);
  write_file_atomically(o.output + "/residuals.csv", residuals);
  if (plates_used) write_file_atomically(o.output + "/plates.csv", plates_text);
  if (estimated) write_file_atomically(o.output + "/ground.csv", ground_text);
  if (check) write_file_atomically(o.output + "/ground_check.csv", check_text);
  write_file_atomically(o.output + "/summary.json", summary_text);
  print_id(o, id, ground.ground, spec, body_weight_N);
  if (check) print_plate_check(*check, character.total_mass_kg());
  for (const std::string& n : notes) std::cout << "  note: " << n << "\n";
  if (unassigned > 0) {
    std::cerr << "WARNING: " << unassigned
              << " loaded plate frames have no single foot on the plate (both feet or neither): "
                 "their load is not applied and stays in the root residual (plates.csv)\n";
  }
  return kExitOk;
}

}  // namespace

IdGround id_ground(const IdSettings& s) {
  IdGround out;
  if (s.grf == "none") return out;
  const bool estimate = is_estimate(s.grf);
  if (!estimate && s.grf != "from-c3d" && s.grf != "plates") {
    throw sim::InvalidArgument(
        "--grf: expected none, plates (or from-c3d), estimate (or "
        "contact), got '" +
        s.grf + "'");
  }
  if (!estimate && s.c3d.empty()) {
    throw sim::InvalidArgument("--grf " + s.grf + ": give the capture with --c3d FILE");
  }
  if (estimate) out.ground = mocap_io::GroundForces::kEstimated;
  if (s.c3d.empty()) return out;
  const mocap_io::C3dFile c3d = mocap_io::read_c3d(s.c3d);
  if (c3d.force_plates.empty()) {
    if (estimate) return out;  // nothing to check the estimate against
    throw sim::InvalidArgument("--c3d " + s.c3d + ": has no force plates");
  }
  if (s.lab_up != "z" && s.lab_up != "y") {
    throw sim::InvalidArgument("--lab-up: expected z or y, got '" + s.lab_up + "'");
  }
  if (!estimate) out.ground = mocap_io::GroundForces::kForcePlates;
  out.plates = c3d.force_plates;
  to_z_up(&out.plates, s.lab_up);
  out.plate_rate_hz = c3d.analog.rate_hz;
  return out;
}

MotionId run_motion_id(const mjModel& model, const mocap_io::Motion& all, const IdSettings& s,
                       const IdGround& ground, const std::string& command,
                       std::vector<std::string>* notes) {
  mocap_io::InverseDynamicsOptions options;
  options.filter.cutoff_hz = s.cutoff_hz;
  options.ground = ground.ground;
  MotionId out;
  out.motion = mocap_io::longest_solved_span(all, &out.first_frame);
  int solved = 0;
  for (int f = 0; f < all.frame_count(); ++f) solved += all.qpos.row(f).allFinite() ? 1 : 0;
  if (solved > out.motion.frame_count()) {
    // Finite differences need a contiguous run: the longest one is used, and that is said.
    notes->push_back(std::to_string(solved - out.motion.frame_count()) +
                     " solved frames outside the longest run without gaps (frames " +
                     std::to_string(out.first_frame) + "-" +
                     std::to_string(out.first_frame + out.motion.frame_count() - 1) +
                     ") are not used");
  }
  if (!s.c3d.empty() && options.ground == mocap_io::GroundForces::kNone) {
    notes->push_back(
        "--c3d is only read with --grf plates or estimate: its force plates are not "
        "used");
  }
  std::optional<ProgressBar> bar;
  if (!command.empty())
    bar.emplace(command + ": " + std::to_string(out.motion.frame_count()) + " frames");
  out.id =
      mocap_io::inverse_dynamics(model, out.motion, options, ground.plates, ground.plate_rate_hz);
  if (bar) bar->finish();
  out.trim_frames = options.trim_frames;
  return out;
}

Command add_mocap_id_command(CLI::App* mocap) {
  auto idopt = std::make_shared<IdOptions>();
  CLI::App* id_cmd = mocap->add_subcommand(
      "id", "Inverse dynamics of a motion (qpos CSV) on a body: joint torques and residuals");
  id_cmd->add_option("--motion", idopt->motion, "motion CSV (from mocap ik or retarget)")
      ->required();
  idopt->character.add_to(id_cmd);
  id_cmd
      ->add_option("--grf", idopt->settings.grf,
                   "ground reaction: none (all in the root residual), plates (the capture's "
                   "force plates; needs --c3d; also from-c3d), estimate (from the kinematics: "
                   "sole points near the floor and slow; also contact; with --c3d's plates, "
                   "checked against them)")
      ->capture_default_str();
  id_cmd->add_option("--c3d", idopt->settings.c3d, "the C3D the motion came from (force plates)");
  id_cmd
      ->add_option("--lab-up", idopt->settings.lab_up,
                   "vertical axis of the capture lab (as given to mocap ik): z or y")
      ->capture_default_str();
  id_cmd->add_option("--cutoff", idopt->settings.cutoff_hz, "low-pass cut-off, Hz (0: no filter)")
      ->capture_default_str();
  id_cmd->add_option("-o,--output", idopt->output, "output directory")->required();
  return {id_cmd, [idopt]() { return run_id(*idopt); }};
}

}  // namespace biodyn::apps
