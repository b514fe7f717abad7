// biodyn muscles: the Hill muscles (issue 25). `muscles curves` writes the normalised Thelen 2003
// curves (muscles/hill_curves.h) and, for one muscle of a generated body, its isometric
// force-angle and moment-angle curves over a joint's range.
#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <iterator>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "biodyn/models/character.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/muscles/hill_curves.h"
#include "biodyn/muscles/muscle_set.h"
#include "biodyn/muscles/muscle_tendon_unit.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/units.h"
#include "cli_common.h"
#include "commands.h"

namespace biodyn::apps {
namespace {

// The curves' domains on integer grids, so the documented points (l~ = 1, v~ = -1,
// strain = 0.04) are samples exactly: l~ = i/100 for i in [40, 180], v~ = i/100 for i in
// [-100, 100], strain = i/10000 for i in [0, 600].
constexpr int kLengthFrom = 40, kLengthTo = 180, kLengthScale = 100;
constexpr int kVelocityFrom = -100, kVelocityTo = 100, kVelocityScale = 100;
constexpr int kStrainFrom = 0, kStrainTo = 600, kStrainScale = 10000;
/// deg: a ball joint's axes are swept over +-45 deg (as the moment-arm tests do).
constexpr double kBallSweep_deg = 45.0;
constexpr double kAngleStep_deg = 1.0;

struct CurvesOptions {
  CharacterOptions character;
  std::string muscle;  ///< empty: the normalised curves only
  std::string dof;     ///< empty: the DOF of the muscle's largest moment arm standing
  std::string tendon = "default";
  std::string output;
};

/// One normalised curve: its name (the CSV's `curve` column), abscissa name and samples.
struct Curve {
  const char* name;
  const char* x_label;
  int from, to, scale;
  double (*value)(double, const muscles::HillCurveParams&);
  double (*slope)(double, const muscles::HillCurveParams&);
};

const Curve kCurves[] = {
    {"active_force_length", "normalised fibre length l/l_opt", kLengthFrom, kLengthTo, kLengthScale,
     muscles::active_force_length, muscles::active_force_length_slope},
    {"passive_force_length", "normalised fibre length l/l_opt", kLengthFrom, kLengthTo,
     kLengthScale, muscles::passive_force_length, muscles::passive_force_length_slope},
    {"force_velocity", "normalised fibre velocity v/v_max (< 0 shortening)", kVelocityFrom,
     kVelocityTo, kVelocityScale, muscles::force_velocity, muscles::force_velocity_slope},
    {"tendon_force_strain", "tendon strain (l_T - l_slack)/l_slack", kStrainFrom, kStrainTo,
     kStrainScale, muscles::tendon_force_strain, muscles::tendon_force_strain_slope},
};

/// curves.csv: curve,x,value,slope (force in units of F_max, x normalised as the curve says).
std::string curves_csv(const muscles::HillCurveParams& c) {
  std::ostringstream out;
  out.precision(12);
  out << "curve,x,value,slope\n";
  for (const Curve& k : kCurves) {
    for (int i = k.from; i <= k.to; ++i) {
      const double x = static_cast<double>(i) / k.scale;
      out << k.name << "," << x << "," << k.value(x, c) << "," << k.slope(x, c) << "\n";
    }
  }
  return out.str();
}

/// curves_plot.dat, curves.gp and curves.png: the four curves, one panel each.
void plot_curves(const std::string& dir, const muscles::HillCurveParams& c) {
  std::ostringstream data;
  data.precision(9);
  for (const Curve& k : kCurves) {
    data << "# " << k.name << "\n";
    for (int i = k.from; i <= k.to; ++i) {
      const double x = static_cast<double>(i) / k.scale;
      data << x << " " << k.value(x, c) << "\n";
    }
    data << "\n\n";
  }
  write_file_atomically(dir + "/curves_plot.dat", data.str());
  std::ostringstream gp;
  gp << "set terminal pngcairo size 1200,900 font 'sans,10' noenhanced\n"
     << "set output '" << dir << "/curves.png.tmp'\n"
     << "set multiplot layout 2,2 title 'Hill muscle curves (Thelen 2003), force / F_max'\n"
     << "set grid\nset ylabel 'force / F_max'\n";
  const char* titles[] = {"active force-length f_L", "passive force-length f_PE",
                          "force-velocity f_V", "tendon force-strain F_T"};
  for (std::size_t p = 0; p < std::size(kCurves); ++p) {
    gp << "set title '" << titles[p] << "'\nset xlabel '" << kCurves[p].x_label << "'\n"
       << "plot '" << dir << "/curves_plot.dat' index " << p
       << " with lines lw 2 lc rgb '#c03030' notitle\n";
  }
  gp << "unset multiplot\n";
  write_file_atomically(dir + "/curves.gp", gp.str());
  plot_with_gnuplot("muscles curves", dir + "/curves.gp", dir + "/curves.png.tmp",
                    dir + "/curves.png");
}

/// The index in `params` of the muscle `name` names: a full name ("soleus_l") or a base name
/// ("soleus": the right side). Throws sim::InvalidArgument naming it and listing the muscles.
int find_muscle(const std::vector<muscles::MuscleParams>& params, const std::string& name) {
  for (const std::string& candidate : {name, name + "_r"}) {
    for (std::size_t i = 0; i < params.size(); ++i)
      if (params[i].name == candidate) return static_cast<int>(i);
  }
  std::string bases;
  for (const muscles::MuscleParams& p : params) {
    const std::string base = p.name.substr(0, p.name.size() - 2);
    if (p.name.compare(p.name.size() - 2, 2, "_r") == 0)
      bases += (bases.empty() ? "" : ", ") + base;
  }
  throw sim::InvalidArgument("--muscle: no muscle '" + name + "' (muscles: " + bases +
                             "; the right side's unless _l or _r is added)");
}

/// A DOF's name: its hinge's, or "<ball>_x/_y/_z" (the actuators' naming, models/mjcf.h).
std::string dof_name(const mjModel& m, int dof) {
  const int j = m.dof_jntid[dof];
  std::string name = mj_id2name(&m, mjOBJ_JOINT, j);
  if (m.jnt_type[j] == mjJNT_BALL) name += std::string("_") + "xyz"[dof - m.jnt_dofadr[j]];
  return name;
}

/// Puts `m`'s standing pose in `d` with DOF `dof` at `angle_rad` (a ball turned about that axis)
/// and computes the tendons' lengths and Jacobians.
void pose_dof(const mjModel& m, mjData* d, int dof, double angle_rad) {
  std::copy(m.qpos0, m.qpos0 + m.nq, d->qpos);
  const int j = m.dof_jntid[dof], adr = m.jnt_qposadr[j];
  if (m.jnt_type[j] == mjJNT_BALL) {
    const int axis = dof - m.jnt_dofadr[j];
    d->qpos[adr] = std::cos(angle_rad / 2);
    for (int k = 0; k < 3; ++k) d->qpos[adr + 1 + k] = k == axis ? std::sin(angle_rad / 2) : 0.0;
  } else {
    d->qpos[adr] = angle_rad;
  }
  mj_kinematics(&m, d);
  mj_comPos(&m, d);
  mj_tendon(&m, d);
}

/// The muscle's isometric state at path length `l_mtu_m`: fibre at rest, tendon as its model.
muscles::MuscleKinematics isometric(const muscles::MuscleParams& p, double activation,
                                    double l_mtu_m) {
  if (p.tendon == muscles::TendonModel::kRigid)
    return muscles::rigid_tendon_state(p, activation, l_mtu_m, 0.0);
  const double rest = muscles::equilibrium_fiber_length(p, activation, l_mtu_m);
  return muscles::compliant_tendon_step(p, activation, rest, l_mtu_m, 1.0);
}

/// One muscle held isometric across one DOF's range (the others standing), at full activation
/// and passive (activation 0).
struct IsometricCurve {
  std::string muscle, dof;
  double from_deg = 0, to_deg = 0;
  std::vector<double> angle_deg, length_m, arm_m, fiber_m, force_N, passive_N;
};

/// The curve of muscle `i` of `set` about `dof_option` (empty: the DOF of its largest moment arm
/// standing). Throws sim::InvalidArgument for a DOF the muscle does not span, listing those it
/// does.
IsometricCurve isometric_curve(const mjModel& m, const muscles::MuscleSet& set, int i,
                               const std::string& dof_option) {
  sim::Data data(m);
  Eigen::MatrixXd R(static_cast<Eigen::Index>(set.covered_dofs().size()), set.size());
  pose_dof(m, data.get(), set.covered_dofs().front(), 0.0);
  set.moment_arms(m, *data, &R);
  int row = -1;
  std::string spanned;
  for (std::size_t k = 0; k < set.covered_dofs().size(); ++k) {
    const auto& of = set.muscles_of_dof()[k];
    if (std::find(of.begin(), of.end(), i) == of.end()) continue;
    const std::string name = dof_name(m, set.covered_dofs()[k]);
    spanned += (spanned.empty() ? "" : ", ") + name;
    const auto r = static_cast<Eigen::Index>(k);
    if (dof_option.empty() ? row < 0 || std::abs(R(r, i)) > std::abs(R(row, i))
                           : name == dof_option)
      row = static_cast<int>(k);
  }
  const std::string& muscle = set.params(i).name;
  if (row < 0) {
    throw sim::InvalidArgument("--dof: " + muscle + " does not span '" + dof_option +
                               "' (it spans " + spanned + ")");
  }
  const int dof = set.covered_dofs()[static_cast<std::size_t>(row)];
  IsometricCurve c;
  c.muscle = muscle;
  c.dof = dof_name(m, dof);
  const int j = m.dof_jntid[dof];
  const bool ball = m.jnt_type[j] == mjJNT_BALL;
  // Whole degrees within the range (its radians miss the degrees it was given by rounding).
  constexpr double kRounding_deg = 1e-6;
  c.from_deg = ball ? -kBallSweep_deg : std::ceil(m.jnt_range[2 * j] * kDegPerRad - kRounding_deg);
  c.to_deg =
      ball ? kBallSweep_deg : std::floor(m.jnt_range[2 * j + 1] * kDegPerRad + kRounding_deg);
  const muscles::MuscleParams& p = set.params(i);
  for (double deg = c.from_deg; deg <= c.to_deg + 1e-9; deg += kAngleStep_deg) {
    pose_dof(m, data.get(), dof, deg / kDegPerRad);
    set.moment_arms(m, *data, &R);
    const double l = set.length(*data, i);
    const muscles::MuscleKinematics active = isometric(p, 1.0, l);
    c.angle_deg.push_back(deg);
    c.length_m.push_back(l);
    c.arm_m.push_back(R(row, i));
    c.fiber_m.push_back(active.fiber_length_m);
    c.force_N.push_back(active.tendon_force_N);
    c.passive_N.push_back(isometric(p, 0.0, l).tendon_force_N);
  }
  return c;
}

/// <muscle>_isometric.csv: per angle the path length, moment arm (r = -dl/dq: positive turns the
/// DOF positive), fibre length and force at full activation, the moment r F, and the passive
/// force and moment.
std::string isometric_csv(const IsometricCurve& c) {
  std::ostringstream out;
  out.precision(9);
  out << "angle_deg,path_length_m,moment_arm_m,fiber_length_m,force_N,moment_Nm,passive_force_N,"
         "passive_moment_Nm\n";
  for (std::size_t k = 0; k < c.angle_deg.size(); ++k) {
    out << c.angle_deg[k] << "," << c.length_m[k] << "," << c.arm_m[k] << "," << c.fiber_m[k] << ","
        << c.force_N[k] << "," << c.arm_m[k] * c.force_N[k] << "," << c.passive_N[k] << ","
        << c.arm_m[k] * c.passive_N[k] << "\n";
  }
  return out.str();
}

/// <muscle>_isometric_plot.dat, .gp and .png: force and moment against the angle.
void plot_isometric(const std::string& dir, const IsometricCurve& c, const std::string& body,
                    const std::string& tendon) {
  const std::string stem = dir + "/" + c.muscle + "_isometric";
  std::ostringstream data;
  data.precision(9);
  for (std::size_t k = 0; k < c.angle_deg.size(); ++k) {
    data << c.angle_deg[k] << " " << c.force_N[k] << " " << c.passive_N[k] << " "
         << c.arm_m[k] * c.force_N[k] << " " << c.arm_m[k] * c.passive_N[k] << "\n";
  }
  write_file_atomically(stem + "_plot.dat", data.str());
  std::ostringstream gp;
  gp << "set terminal pngcairo size 1000,900 font 'sans,10' noenhanced\n"
     << "set output '" << stem << ".png.tmp'\n"
     << "set multiplot layout 2,1 title '" << c.muscle << " isometric about " << c.dof << " ("
     << body << ", " << tendon << " tendon)'\n"
     << "set grid\nset key top left\nset xlabel '" << c.dof << " (deg)'\n"
     << "set title 'Force along the path'\nset ylabel 'N'\n"
     << "plot '" << stem << "_plot.dat' using 1:2 with lines lw 2 lc rgb '#c03030' title "
     << "'full activation', '' using 1:3 with lines lw 2 dt 2 lc rgb '#3060c0' title 'passive'\n"
     << "set title 'Moment about " << c.dof << " (positive turns it positive)'\nset ylabel 'N m'\n"
     << "plot '" << stem << "_plot.dat' using 1:4 with lines lw 2 lc rgb '#c03030' title "
     << "'full activation', '' using 1:5 with lines lw 2 dt 2 lc rgb '#3060c0' title 'passive'\n"
     << "unset multiplot\n";
  write_file_atomically(stem + ".gp", gp.str());
  plot_with_gnuplot("muscles curves", stem + ".gp", stem + ".png.tmp", stem + ".png");
}

std::string body_label(const models::CharacterSpec& s) {
  std::ostringstream out;
  out << s.height_m << " m, " << s.mass_kg << " kg, " << models::to_string(s.sex);
  return out.str();
}

int run_curves(const CurvesOptions& o) {
  check_outputs({{"-o", o.output, true}}, {o.character.overrides_path, o.character.body_path});
  const muscles::HillCurveParams curves;  // Thelen 2003's (every muscle of the body uses them)
  const std::string csv = curves_csv(curves);
  IsometricCurve iso;
  std::string iso_csv, tendon, body;
  if (!o.muscle.empty()) {
    models::CharacterSpec spec = o.character.to_spec();
    spec.muscles = true;
    const models::Character character = models::generate_character(spec);
    const sim::Model model = sim::Model::from_string(models::to_mjcf(character), "character");
    const muscles::MuscleSet set(
        *model, muscles::muscle_params(character.muscles,
                                       muscles::parse_tendon_choice(o.tendon, "--tendon")));
    const int i = find_muscle(set.params(), o.muscle);
    iso = isometric_curve(*model, set, i, o.dof);
    iso_csv = isometric_csv(iso);
    tendon = muscles::to_string(set.params(i).tendon);
    body = body_label(spec);
  }
  std::filesystem::create_directories(o.output);
  plot_curves(o.output, curves);
  if (!iso.muscle.empty()) plot_isometric(o.output, iso, body, tendon);
  write_file_atomically(o.output + "/curves.csv", csv);
  std::cout << "wrote " << o.output
            << "/curves.csv and curves.png: f_L(1) = " << muscles::active_force_length(1.0, curves)
            << ", f_V(-1) = " << muscles::force_velocity(-1.0, curves)
            << ", F_T(0.04) = " << muscles::tendon_force_strain(0.04, curves) << "\n";
  if (iso.muscle.empty()) return kExitOk;
  const std::string stem = o.output + "/" + iso.muscle + "_isometric";
  write_file_atomically(stem + ".csv", iso_csv);
  const auto peak = std::max_element(iso.force_N.begin(), iso.force_N.end()) - iso.force_N.begin();
  std::size_t peak_moment = 0;
  for (std::size_t k = 0; k < iso.angle_deg.size(); ++k) {
    if (std::abs(iso.arm_m[k] * iso.force_N[k]) >
        std::abs(iso.arm_m[peak_moment] * iso.force_N[peak_moment]))
      peak_moment = k;
  }
  const auto at = static_cast<std::size_t>(peak);
  std::cout << "wrote " << stem << ".csv and .png: " << iso.muscle << " (" << body << ", " << tendon
            << " tendon) about " << iso.dof << " over [" << iso.from_deg << ", " << iso.to_deg
            << "] deg: peak force " << iso.force_N[at] << " N at " << iso.angle_deg[at]
            << " deg, peak moment " << iso.arm_m[peak_moment] * iso.force_N[peak_moment]
            << " N m at " << iso.angle_deg[peak_moment] << " deg\n";
  return kExitOk;
}

Command add_muscles_curves_command(CLI::App* muscles_cmd) {
  auto o = std::make_shared<CurvesOptions>();
  CLI::App* cmd = muscles_cmd->add_subcommand(
      "curves",
      "The normalised Hill curves (Thelen 2003) as CSV and PNG; with --muscle, that muscle's "
      "isometric force and moment across a joint's range on the generated body");
  cmd->add_option("-o,--output", o->output, "output directory")->required();
  cmd->add_option("--muscle", o->muscle,
                  "a muscle of the legs, e.g. soleus (the right one) or soleus_l: its isometric "
                  "force-angle curve");
  cmd->add_option("--dof", o->dof,
                  "the DOF to sweep, e.g. knee_flexion_r or hip_r_y (default: the one the "
                  "muscle has its largest moment arm about, standing)");
  cmd->add_option("--tendon", o->tendon,
                  "default (compliant soleus and gastrocnemius, rigid others), rigid or compliant")
      ->capture_default_str();
  o->character.add_to(cmd);
  return {cmd, [o]() { return run_curves(*o); }};
}

}  // namespace

Command add_muscles_command(CLI::App* app) {
  CLI::App* muscles_cmd =
      app->add_subcommand("muscles", "The legs' Hill muscles (Thelen 2003, Rajagopal 2016)");
  muscles_cmd->require_subcommand(1);
  const std::vector<Command> subcommands = {add_muscles_curves_command(muscles_cmd)};
  return {muscles_cmd, [subcommands]() {
            for (const Command& c : subcommands) {
              if (c.cli->parsed()) return c.run();
            }
            return kExitBadInput;  // not reached: CLI11 requires one subcommand
          }};
}

}  // namespace biodyn::apps
