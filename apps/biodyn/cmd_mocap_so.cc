// biodyn mocap so: static optimisation (issue 25): the joint torques inverse dynamics finds for a
// motion, shared frame by frame among the legs' Hill muscles (muscles/static_optimization.h),
// with reserve torques for what the muscles cannot give; activations over the gait cycle against
// the textbook EMG on-times (references.md).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/mocap_io/gait_events.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/muscles/muscle_set.h"
#include "biodyn/muscles/static_optimization.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "cli_common.h"
#include "cmd_mocap.h"

namespace biodyn::apps {
namespace {

using nlohmann::json;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
/// The longest muscle description shown in a panel's title (characters).
constexpr std::size_t kTitleChars = 48;
/// Points of a gait-cycle profile: every 1 % from 0 to 100 %.
constexpr int kCyclePoints = 101;
/// s: the most a time in --id's torques.csv may differ from the motion's frame (the file has 9
/// significant digits).
constexpr double kTimeTolerance_s = 1e-6;
/// Relative difference of --id's body from this one's beyond which it is another body.
constexpr double kBodyTolerance = 1e-6;

struct SoOptions {
  std::string motion, id_dir, muscle_params, output, dof_weights;
  IdSettings settings;
  CharacterOptions character;
  double reserve_weight = muscles::StaticOptimizationParams{}.reserve_weight_per_Nm2;
};

/// Textbook EMG on-times over the gait cycle (% from heel strike), references.md: "Normative
/// adult walking (Winter 2009; Perry & Burnfield 2010)". A run past 100 % is split in two.
struct EmgReference {
  const char* muscle;  ///< base name (no side)
  std::vector<std::pair<double, double>> on_percent;
};

const std::vector<EmgReference>& emg_references() {
  static const std::vector<EmgReference> table = {{"tib_ant", {{0, 15}, {60, 100}}},
                                                  {"soleus", {{10, 50}}},
                                                  {"gastroc", {{15, 50}}},
                                                  {"vasti", {{95, 100}, {0, 15}}},
                                                  {"hamstrings", {{80, 100}, {0, 10}}},
                                                  {"glut_max", {{95, 100}, {0, 20}}},
                                                  {"glut_med", {{95, 100}, {0, 35}}},
                                                  {"iliopsoas", {{50, 75}}},
                                                  {"rect_fem", {{55, 65}}}};
  return table;
}

/// The reference of a muscle, or of the muscle it is a part of ("glut_med_ant": "glut_med").
const EmgReference* emg_reference(const std::string& base) {
  for (const EmgReference& r : emg_references()) {
    const std::string name = r.muscle;
    if (base == name || base.rfind(name + "_", 0) == 0) return &r;
  }
  return nullptr;
}

/// "soleus_r" -> "soleus"; the side from the suffix (-1 when none).
std::string base_name(const std::string& muscle, int* side) {
  *side = -1;
  for (int s = 0; s < 2; ++s) {
    const std::string suffix = models::kSideSuffix[s];
    if (muscle.size() > suffix.size() &&
        muscle.compare(muscle.size() - suffix.size(), suffix.size(), suffix) == 0) {
      *side = s;
      return muscle.substr(0, muscle.size() - suffix.size());
    }
  }
  return muscle;
}

const char* side_name(int side) { return side == models::kLeft ? "left" : "right"; }

/// A DOF's name without its side: "hip_r_z" -> "hip_z", "knee_flexion_l" -> "knee_flexion".
std::string sideless(const std::string& dof) {
  for (const char* side : {"_l", "_r"}) {
    const std::string s = side;
    const std::size_t mid = dof.find(s + "_");
    if (mid != std::string::npos) return dof.substr(0, mid) + dof.substr(mid + s.size());
    if (dof.size() > s.size() && dof.compare(dof.size() - s.size(), s.size(), s) == 0)
      return dof.substr(0, dof.size() - s.size());
  }
  return dof;
}

/// The static optimisation parameters: --reserve-weight, and --reserve-weights
/// "NAME=W,..." with NAME a DOF the muscles span (hip_r_z) or such a name without its side
/// (hip_z: both legs). Throws sim::InvalidArgument naming the option, the entry and the DOFs.
muscles::StaticOptimizationParams so_params(const SoOptions& o, const mjModel& model,
                                            const muscles::MuscleSet& set) {
  muscles::StaticOptimizationParams p;
  p.reserve_weight_per_Nm2 = o.reserve_weight;
  const std::vector<std::string> names = mocap_io::dof_names(model);
  std::string covered;
  for (int dof : set.covered_dofs())
    covered += (covered.empty() ? "" : ", ") + names[static_cast<std::size_t>(dof)];
  std::stringstream in(o.dof_weights);
  for (std::string entry; std::getline(in, entry, ',');) {
    const std::size_t eq = entry.find('=');
    const std::string name = entry.substr(0, eq);
    char* end = nullptr;
    const double w = eq == std::string::npos ? 0.0 : std::strtod(entry.c_str() + eq + 1, &end);
    if (eq == std::string::npos || end == entry.c_str() + eq + 1 || *end != '\0' ||
        !(w > 0 && std::isfinite(w))) {
      throw sim::InvalidArgument("--reserve-weights: expected NAME=W with W > 0, got '" + entry +
                                 "'");
    }
    bool matched = false;
    for (int dof : set.covered_dofs()) {
      const std::string& n = names[static_cast<std::size_t>(dof)];
      if (name != n && name != sideless(n)) continue;
      p.reserve_weight_of_dof_per_Nm2[dof] = w;
      matched = true;
    }
    if (!matched) {
      throw sim::InvalidArgument("--reserve-weights: no DOF the muscles span is called '" + name +
                                 "' (they span " + covered +
                                 "; a name without _l/_r sets both legs)");
    }
  }
  return p;
}

// --- --id DIR: the torques mocap id wrote -------------------------------------------------------

/// A CSV file: its header's names and its rows' fields, with their line numbers.
struct CsvTable {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  std::vector<int> lines;
};

std::vector<std::string> split_commas(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream in(line);
  for (std::string f; std::getline(in, f, ',');) out.push_back(f);
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

/// Reads `path` as comma-separated values (a header line, then rows of as many fields; '#'
/// lines and blank lines skipped). Throws sim::InvalidArgument naming the file and line.
CsvTable read_csv_table(const std::string& path) {
  std::istringstream in(read_file(path));
  CsvTable t;
  int line_no = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> fields = split_commas(line);
    if (t.header.empty()) {
      t.header = std::move(fields);
      continue;
    }
    if (fields.size() != t.header.size()) {
      throw sim::InvalidArgument(path + ":" + std::to_string(line_no) + ": expected " +
                                 std::to_string(t.header.size()) +
                                 " fields as in the header, got " + std::to_string(fields.size()));
    }
    t.rows.push_back(std::move(fields));
    t.lines.push_back(line_no);
  }
  if (t.header.empty()) throw sim::InvalidArgument(path + ": empty (no header line)");
  return t;
}

/// The number in row `r`, column `c` of `t`; throws sim::InvalidArgument naming the file, line,
/// column and the text found.
double csv_number(const CsvTable& t, const std::string& path, std::size_t r, std::size_t c) {
  const std::string& text = t.rows[r][c];
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(x)) {
    throw sim::InvalidArgument(path + ":" + std::to_string(t.lines[r]) + ": column '" +
                               t.header[c] + "': expected a finite number, got '" + text + "'");
  }
  return x;
}

/// Checks that `t` has one row per time of `times_s` with that time in its first column.
void check_times(const CsvTable& t, const std::string& path, const std::vector<double>& times_s) {
  if (t.rows.size() != times_s.size()) {
    throw sim::InvalidArgument(path + ": " + std::to_string(t.rows.size()) +
                               " rows, but the motion's solved frames give " +
                               std::to_string(times_s.size()) +
                               " (torques of another motion? run mocap id on this one)");
  }
  for (std::size_t r = 0; r < t.rows.size(); ++r) {
    const double time = csv_number(t, path, r, 0);
    if (std::abs(time - times_s[r]) > kTimeTolerance_s) {
      std::ostringstream msg;
      msg << path << ":" << t.lines[r] << ": time " << time << " s, but the motion's frame is at "
          << times_s[r] << " s (torques of another motion? run mocap id on this one)";
      throw sim::InvalidArgument(msg.str());
    }
  }
}

/// What mocap id wrote into DIR and `mocap so` uses.
struct IdDir {
  double cutoff_hz = 0;
  std::string ground;
  json character;
};

/// DIR/summary.json: the filter, the ground and the body of the run. Throws
/// sim::InvalidArgument naming the file and the field.
IdDir read_id_summary(const std::string& dir) {
  const std::string path = dir + "/summary.json";
  json s;
  try {
    s = json::parse(read_file(path));
  } catch (const json::exception& e) {
    throw sim::InvalidArgument(path + ": not valid JSON: " + e.what());
  }
  IdDir out;
  const auto field = [&](const json& j, const char* key, const char* name) -> const json& {
    if (!j.is_object() || !j.contains(key)) {
      throw sim::InvalidArgument(path + ": no field '" + name +
                                 "' (not a summary of biodyn mocap id?)");
    }
    return j[key];
  };
  const json& cutoff = field(field(s, "filter", "filter"), "cutoff_hz", "filter.cutoff_hz");
  if (!cutoff.is_number() || !(cutoff.get<double>() >= 0)) {
    throw sim::InvalidArgument(path + ": filter.cutoff_hz must be a number >= 0, got " +
                               cutoff.dump());
  }
  out.cutoff_hz = cutoff.get<double>();
  const json& ground = field(s, "ground", "ground");
  if (!ground.is_string()) {
    throw sim::InvalidArgument(path + ": ground must be a string, got " + ground.dump());
  }
  out.ground = ground.get<std::string>();
  out.character = field(s, "character", "character");
  return out;
}

/// Refuses torques computed for another body than `spec` (naming the field and both values).
void check_id_body(const json& id_character, const models::CharacterSpec& spec,
                   const std::string& path) {
  const json here = character_json(spec);
  for (const char* key : {"height_m", "mass_kg", "sex", "detail"}) {
    if (!id_character.contains(key)) {
      throw sim::InvalidArgument(path + ": no field 'character." + std::string(key) + "'");
    }
    const json& a = id_character[key];
    const json& b = here[key];
    const bool same =
        a.is_number() && b.is_number()
            ? std::abs(a.get<double>() - b.get<double>()) <= kBodyTolerance * b.get<double>()
            : a == b;
    if (!same) {
      throw sim::InvalidArgument(path + ": character." + key + " is " + a.dump() +
                                 ", but the body here has " + b.dump() +
                                 ": torques of another body (give mocap so the body options "
                                 "mocap id had, e.g. --mass, or run mocap id again)");
    }
  }
}

/// DIR/plates.csv as InverseDynamicsResult::plate_foot (frames x plates).
Eigen::MatrixXi read_plates_csv(const std::string& path, const std::vector<double>& times_s) {
  const CsvTable t = read_csv_table(path);
  check_times(t, path, times_s);
  Eigen::MatrixXi feet(static_cast<Eigen::Index>(t.rows.size()),
                       static_cast<Eigen::Index>(t.header.size()) - 1);
  for (std::size_t r = 0; r < t.rows.size(); ++r) {
    for (std::size_t c = 1; c < t.header.size(); ++c) {
      const std::string& v = t.rows[r][c];
      int foot = 0;
      if (v == "left") {
        foot = models::kLeft;
      } else if (v == "right") {
        foot = models::kRight;
      } else if (v == "unassigned") {
        foot = mocap_io::kPlateUnassigned;
      } else if (v == "unloaded") {
        foot = mocap_io::kPlateUnloaded;
      } else {
        throw sim::InvalidArgument(
            path + ":" + std::to_string(t.lines[r]) + ": column '" + t.header[c] +
            "': expected left, right, unassigned or unloaded, got '" + v + "'");
      }
      feet(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c) - 1) = foot;
    }
  }
  return feet;
}

/// The joint torques static optimisation shares, the states they are for, and where they came
/// from.
struct SoInputs {
  MotionId run;         ///< run.id: filtered qpos, qvel, times (and plate_foot)
  Eigen::MatrixXd tau;  ///< frames x nv, N m / N: the torques to share
  std::string torques_from, ground;
};

/// --id DIR: the kinematics recomputed as mocap id computed them (its cutoff, the motion's
/// longest solved run), the torques read from DIR/torques.csv.
SoInputs inputs_from_id_dir(const SoOptions& o, const mjModel& model, const mocap_io::Motion& all,
                            const models::CharacterSpec& spec, std::vector<std::string>* notes) {
  const IdDir dir = read_id_summary(o.id_dir);
  check_id_body(dir.character, spec, o.id_dir + "/summary.json");
  IdSettings kinematics;
  kinematics.cutoff_hz = dir.cutoff_hz;
  SoInputs in;
  // The kinematics take a fraction of a second: no progress bar, so a refusal of the files below
  // stays the one line on stderr.
  in.run = run_motion_id(model, all, kinematics, IdGround{}, "", notes);
  in.ground = dir.ground;
  in.torques_from = o.id_dir + "/torques.csv (mocap id, ground " + dir.ground + ")";
  const std::string path = o.id_dir + "/torques.csv";
  const CsvTable t = read_csv_table(path);
  const std::vector<std::string>& names = in.run.id.dof_names;
  for (std::size_t c = 0; c <= names.size(); ++c) {
    const std::string want = c == 0 ? "time" : names[c - 1];
    const std::string got = c < t.header.size() ? t.header[c] : "(none)";
    if (got != want) {
      throw sim::InvalidArgument(path + ": column " + std::to_string(c + 1) + " is '" + got +
                                 "', expected '" + want + "' (torques of another body plan?)");
    }
  }
  check_times(t, path, in.run.id.times_s);
  in.tau.resize(static_cast<Eigen::Index>(t.rows.size()), static_cast<Eigen::Index>(names.size()));
  for (std::size_t r = 0; r < t.rows.size(); ++r)
    for (std::size_t c = 0; c < names.size(); ++c)
      in.tau(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) =
          csv_number(t, path, r, c + 1);
  if (std::filesystem::exists(o.id_dir + "/plates.csv")) {
    in.run.id.plate_foot = read_plates_csv(o.id_dir + "/plates.csv", in.run.id.times_s);
  }
  if (!o.settings.c3d.empty()) {
    notes->push_back("--c3d is not used with --id: the torques (and plates.csv) are read from " +
                     o.id_dir);
  }
  return in;
}

/// The torques to share: read (--id) or computed here by inverse dynamics (with the plates of
/// --c3d when given).
SoInputs so_inputs(const SoOptions& o, const IdGround& ground, const mjModel& model,
                   const mocap_io::Motion& all, const models::CharacterSpec& spec,
                   std::vector<std::string>* notes) {
  if (!o.id_dir.empty()) return inputs_from_id_dir(o, model, all, spec, notes);
  SoInputs in;
  in.run = run_motion_id(model, all, o.settings, ground, "mocap so: inverse dynamics", notes);
  in.tau = in.run.id.generalized_force;
  in.ground = o.settings.grf;
  std::ostringstream from;
  from << "inverse dynamics run here (ground " << o.settings.grf << ", low-pass "
       << o.settings.cutoff_hz << " Hz)";
  in.torques_from = from.str();
  return in;
}

// --- Gait cycles ---------------------------------------------------------------------------------

/// One leg's gait cycles and its muscles' activations averaged over them.
struct SideCycles {
  int side = 0;
  std::vector<mocap_io::HeelStrike> strikes;
  std::vector<std::pair<double, double>> cycles;  ///< s: heel strike to the next one
  std::vector<bool> on_plate;                     ///< per cycle: its stance on a force plate
  std::vector<int> used;                          ///< the cycles averaged
  std::vector<int> muscles;                       ///< this leg's muscles (indices)
  Eigen::MatrixXd profile;        ///< kCyclePoints x muscles.size(): mean activation, 0..100 %
  double toe_off_percent = kNaN;  ///< mean over the used cycles seen by a plate
};

SideCycles side_cycles(const mjModel& model, const MotionId& run,
                       const muscles::StaticOptimizationResult& so, const muscles::MuscleSet& set,
                       int side) {
  SideCycles c;
  c.side = side;
  c.strikes = mocap_io::heel_strikes(model, run.id.qpos, run.id.times_s, side, run.id.plate_foot);
  for (int i = 0; i < set.size(); ++i) {
    int s = -1;
    base_name(set.params(i).name, &s);
    if (s == side) c.muscles.push_back(i);
  }
  for (std::size_t k = 0; k + 1 < c.strikes.size(); ++k) {
    c.cycles.emplace_back(c.strikes[k].time_s, c.strikes[k + 1].time_s);
    c.on_plate.push_back(c.strikes[k].plate >= 0);
  }
  // Cycles whose stance the plates measured; all cycles when none was.
  for (std::size_t k = 0; k < c.cycles.size(); ++k)
    if (c.on_plate[k]) c.used.push_back(static_cast<int>(k));
  if (c.used.empty())
    for (std::size_t k = 0; k < c.cycles.size(); ++k) c.used.push_back(static_cast<int>(k));
  if (c.used.empty() || c.muscles.empty()) return c;
  Eigen::MatrixXd activation(so.activation.rows(), static_cast<Eigen::Index>(c.muscles.size()));
  for (std::size_t j = 0; j < c.muscles.size(); ++j)
    activation.col(static_cast<Eigen::Index>(j)) = so.activation.col(c.muscles[j]);
  c.profile.setZero(kCyclePoints, activation.cols());
  double toe_off = 0;
  int toe_offs = 0;
  for (int k : c.used) {
    const auto [t0, t1] = c.cycles[static_cast<std::size_t>(k)];
    c.profile += mocap_io::resample_cycle(run.id.times_s, activation, t0, t1, kCyclePoints);
    const double off = c.strikes[static_cast<std::size_t>(k)].plate_off_time_s;
    if (std::isfinite(off)) {
      toe_off += 100.0 * (off - t0) / (t1 - t0);
      ++toe_offs;
    }
  }
  c.profile /= static_cast<double>(c.used.size());
  if (toe_offs > 0) c.toe_off_percent = toe_off / toe_offs;
  return c;
}

/// How the cycles were found, for summary.json.
json cycles_json(const SideCycles& c) {
  json strikes = json::array();
  for (const mocap_io::HeelStrike& s : c.strikes) {
    json j = {{"time_s", s.time_s},
              {"source", s.plate >= 0 ? "force plate " + std::to_string(s.plate + 1) + " onset"
                                      : std::string("heel kinematics")}};
    j["kinematic_time_s"] = std::isfinite(s.kinematic_time_s) ? json(s.kinematic_time_s) : json();
    if (s.plate >= 0 && std::isfinite(s.kinematic_time_s))
      j["kinematic_minus_plate_s"] = s.kinematic_time_s - s.time_s;
    if (std::isfinite(s.plate_off_time_s)) j["plate_off_time_s"] = s.plate_off_time_s;
    strikes.push_back(j);
  }
  json cycles = json::array();
  for (std::size_t k = 0; k < c.cycles.size(); ++k) {
    const bool used = std::find(c.used.begin(), c.used.end(), static_cast<int>(k)) != c.used.end();
    cycles.push_back({{"from_s", c.cycles[k].first},
                      {"to_s", c.cycles[k].second},
                      {"stance_on_plate", static_cast<bool>(c.on_plate[k])},
                      {"averaged", used}});
  }
  json j = {{"heel_strikes", strikes}, {"cycles", cycles}};
  j["toe_off_percent"] = std::isfinite(c.toe_off_percent) ? json(c.toe_off_percent) : json();
  return j;
}

// --- Outputs -------------------------------------------------------------------------------------

/// CSV: time, then one column per name.
std::string matrix_csv(const std::vector<double>& times_s, const std::vector<std::string>& names,
                       const Eigen::MatrixXd& values) {
  std::ostringstream out;
  out.precision(9);
  out << "time";
  for (const std::string& n : names) out << "," << n;
  out << "\n";
  for (std::size_t i = 0; i < times_s.size(); ++i) {
    out << times_s[i];
    for (Eigen::Index c = 0; c < values.cols(); ++c)
      out << "," << values(static_cast<Eigen::Index>(i), c);
    out << "\n";
  }
  return out.str();
}

/// reserves.csv: per covered DOF the ID torque, the muscles' moment and the reserve.
std::string reserves_csv(const std::vector<double>& times_s,
                         const std::vector<std::string>& dof_names,
                         const muscles::StaticOptimizationResult& so) {
  std::vector<std::string> names;
  const Eigen::Index k = so.tau_Nm.cols();
  Eigen::MatrixXd values(so.tau_Nm.rows(), 3 * k);
  for (Eigen::Index c = 0; c < k; ++c) {
    const std::string& n = dof_names[static_cast<std::size_t>(c)];
    names.insert(names.end(), {n + "_id", n + "_muscles", n + "_reserve"});
    values.col(3 * c) = so.tau_Nm.col(c);
    values.col(3 * c + 1) = so.muscle_moment_Nm.col(c);
    values.col(3 * c + 2) = so.reserve_Nm.col(c);
  }
  return matrix_csv(times_s, names, values);
}

/// Per covered DOF: peak |ID torque|, peak |reserve| and their ratio over `rows` (all when
/// empty).
json reserve_stats(const muscles::StaticOptimizationResult& so, Eigen::Index col,
                   const std::vector<Eigen::Index>& rows) {
  double tau = 0, reserve = 0, reserve_time_row = -1;
  for (Eigen::Index r = 0; r < so.tau_Nm.rows(); ++r) {
    if (!rows.empty() && std::find(rows.begin(), rows.end(), r) == rows.end()) continue;
    tau = std::max(tau, std::abs(so.tau_Nm(r, col)));
    if (std::abs(so.reserve_Nm(r, col)) > reserve) {
      reserve = std::abs(so.reserve_Nm(r, col));
      reserve_time_row = static_cast<double>(r);
    }
  }
  json j = {{"peak_abs_id_torque_Nm", tau}, {"peak_abs_reserve_Nm", reserve}};
  j["reserve_to_peak_ratio"] = tau > 0 ? json(reserve / tau) : json();
  j["peak_reserve_row"] = reserve_time_row;
  return j;
}

/// Frames (rows) inside the cycles `c` averaged.
std::vector<Eigen::Index> cycle_rows(const SideCycles& c, const std::vector<double>& times_s) {
  std::vector<Eigen::Index> rows;
  for (std::size_t r = 0; r < times_s.size(); ++r) {
    for (int k : c.used) {
      const auto [t0, t1] = c.cycles[static_cast<std::size_t>(k)];
      if (times_s[r] >= t0 && times_s[r] <= t1) {
        rows.push_back(static_cast<Eigen::Index>(r));
        break;
      }
    }
  }
  return rows;
}

/// summary.json's "dofs": each covered DOF's torque and reserve peaks, over all frames and over
/// its leg's averaged cycles.
json dofs_json(const muscles::StaticOptimizationResult& so, const muscles::MuscleSet& set,
               const std::vector<std::string>& dof_names, const std::vector<double>& times_s,
               const SideCycles cycles[2]) {
  json dofs = json::object();
  for (std::size_t k = 0; k < set.covered_dofs().size(); ++k) {
    const Eigen::Index col = static_cast<Eigen::Index>(k);
    int side = -1;
    base_name(set.params(set.muscles_of_dof()[k].front()).name, &side);
    json j = reserve_stats(so, col, {});
    const auto time_of = [&](json* s) {
      const double row = (*s)["peak_reserve_row"].get<double>();
      (*s)["peak_reserve_time_s"] =
          row >= 0 ? json(times_s[static_cast<std::size_t>(row)]) : json();
      s->erase("peak_reserve_row");
    };
    time_of(&j);
    j["muscles"] = set.muscles_of_dof()[k].size();
    if (side >= 0 && !cycles[side].used.empty()) {
      json in_cycles = reserve_stats(so, col, cycle_rows(cycles[side], times_s));
      time_of(&in_cycles);
      j["in_averaged_cycles"] = in_cycles;
    }
    dofs[dof_names[static_cast<std::size_t>(set.covered_dofs()[k])]] = j;
  }
  return dofs;
}

/// summary.json's "muscles": peak activation over all frames and, over its leg's averaged
/// cycles, the profile's peak and where in the cycle it is; the reference EMG on-times.
json muscles_json(const muscles::StaticOptimizationResult& so, const muscles::MuscleSet& set,
                  const std::vector<double>& times_s, const SideCycles cycles[2]) {
  json out = json::object();
  for (int i = 0; i < set.size(); ++i) {
    int side = -1;
    const std::string base = base_name(set.params(i).name, &side);
    Eigen::Index row = 0;
    const double peak = so.activation.col(i).maxCoeff(&row);
    json j = {{"peak_activation", peak},
              {"peak_time_s", times_s[static_cast<std::size_t>(row)]},
              {"peak_force_N", so.force_N.col(i).maxCoeff()},
              {"max_isometric_force_N", set.params(i).max_isometric_force_N}};
    if (side >= 0 && cycles[side].profile.size() > 0) {
      const SideCycles& c = cycles[side];
      const auto pos = std::find(c.muscles.begin(), c.muscles.end(), i) - c.muscles.begin();
      Eigen::Index at = 0;
      j["cycle_mean_peak_activation"] = c.profile.col(pos).maxCoeff(&at);
      j["cycle_mean_peak_percent"] = 100.0 * static_cast<double>(at) / (kCyclePoints - 1);
    }
    if (const EmgReference* ref = emg_reference(base)) {
      json on = json::array();
      for (const auto& [a, b] : ref->on_percent) on.push_back({a, b});
      j["reference_emg_on_percent"] = on;
    }
    out[set.params(i).name] = j;
  }
  return out;
}

/// gnuplot's data: per muscle of the plotted leg (a block each), % cycle, the plotted leg's mean
/// activation and the other leg's (NaN when it has no cycle).
std::string profile_data(const SideCycles& main, const SideCycles& other) {
  std::ostringstream data;
  data.precision(6);
  for (std::size_t j = 0; j < main.muscles.size(); ++j) {
    for (int p = 0; p < kCyclePoints; ++p) {
      const double o = other.profile.size() > 0 && j < other.muscles.size()
                           ? other.profile(p, static_cast<Eigen::Index>(j))
                           : kNaN;
      data << 100.0 * p / (kCyclePoints - 1) << " " << main.profile(p, static_cast<Eigen::Index>(j))
           << " " << o << "\n";
    }
    data << "\n\n";
  }
  return data.str();
}

/// activations.png: the legs' activations over the gait cycle, each muscle beside its textbook
/// EMG on-times (grey bars at the top), the plate's toe off dashed.
void plot_activations(const std::string& dir, const SideCycles& main, const SideCycles& other,
                      const muscles::MuscleSet& set, const std::vector<std::string>& descriptions) {
  write_file_atomically(dir + "/activations_plot.dat", profile_data(main, other));
  // Three panels per row, as many rows as the muscles need (one leg's set).
  const int rows = static_cast<int>((main.muscles.size() + 2) / 3);
  std::ostringstream gp;
  gp << "set terminal pngcairo size 1500," << 330 * rows << " font 'sans,10' noenhanced\n"
     << "set output '" << dir << "/activations.png.tmp'\n"
     << "set multiplot layout " << rows
     << ",3 title \"Static optimisation: activations over the gait cycle (" << side_name(main.side)
     << " leg solid, from its heel strike; " << side_name(other.side)
     << " leg dashed, from its own)\\ngrey bars: textbook EMG on-times (Winter 2009; Perry & "
        "Burnfield 2010; references.md); dotted: toe off on the plate; rigid tendons\"\n"
     << "set xrange [0:100]\nset xtics 0,20,100\nset grid\nset xlabel '% gait cycle'\n"
     << "set ylabel 'activation'\nset key at graph 0.99, graph 0.87 right top font ',8' "
        "samplen 2\n";
  for (std::size_t j = 0; j < main.muscles.size(); ++j) {
    int side = -1;
    const std::string base = base_name(set.params(main.muscles[j]).name, &side);
    const double top = std::max({main.profile.col(static_cast<Eigen::Index>(j)).maxCoeff(),
                                 other.profile.size() > 0 && j < other.muscles.size()
                                     ? other.profile.col(static_cast<Eigen::Index>(j)).maxCoeff()
                                     : 0.0,
                                 0.05}) *
                       1.3;
    gp << "unset object\nunset arrow\nset yrange [0:" << top << "]\n";
    int n = 1;
    if (const EmgReference* ref = emg_reference(base)) {
      for (const auto& [a, b] : ref->on_percent) {
        gp << "set object " << n++ << " rect from first " << a << ", graph 0.9 to first " << b
           << ", graph 1 fc rgb '#999999' fillstyle solid 0.7 noborder\n";
      }
    }
    if (std::isfinite(main.toe_off_percent)) {
      gp << "set arrow from first " << main.toe_off_percent << ", graph 0 to first "
         << main.toe_off_percent << ", graph 1 nohead dt 3 lc rgb '#444444'\n";
    }
    const std::string& d = descriptions[static_cast<std::size_t>(main.muscles[j])];
    gp << "set title \"" << base << ": " << d.substr(0, std::min(d.find(':'), kTitleChars))
       << "\"\n"
       << "plot '" << dir << "/activations_plot.dat' index " << j
       << " using 1:2 with lines lw 2 lc rgb '#b2182b' title '" << side_name(main.side) << "', '"
       << dir << "/activations_plot.dat' index " << j
       << " using 1:3 with lines lw 1.5 dt 2 lc rgb '#2166ac' title '" << side_name(other.side)
       << "'\n";
  }
  gp << "unset multiplot\n";
  write_file_atomically(dir + "/activations.gp", gp.str());
  plot_with_gnuplot("mocap so", dir + "/activations.gp", dir + "/activations.png.tmp",
                    dir + "/activations.png");
}

/// The per-DOF reserve weights that differ from the default, by DOF name.
json dof_weights_json(const muscles::StaticOptimization& so,
                      const std::vector<std::string>& names) {
  json out = json::object();
  for (const auto& [dof, w] : so.params().reserve_weight_of_dof_per_Nm2)
    out[names[static_cast<std::size_t>(dof)]] = w;
  return out;
}

/// What static optimisation was run on and how, for summary.json.
json so_summary(const SoOptions& o, const SoInputs& in, const muscles::StaticOptimization& so_def,
                const muscles::StaticOptimizationResult& so, const models::CharacterSpec& spec,
                const SideCycles cycles[2]) {
  const mocap_io::InverseDynamicsResult& id = in.run.id;
  const double frames = static_cast<double>(id.times_s.size());
  return {
      {"motion", o.motion},
      {"frames", id.times_s.size()},
      {"first_frame_used", in.run.first_frame + in.run.trim_frames},
      {"time_span_s", {id.times_s.front(), id.times_s.back()}},
      {"character", character_json(spec)},
      {"torques_from", in.torques_from},
      {"ground", in.ground},
      {"muscles_source", models::muscle_table_source()},
      {"muscle_params", o.muscle_params.empty() ? json() : json(o.muscle_params)},
      {"tendon_model",
       "rigid for every muscle (static optimisation has no fibre state to integrate: the fibre "
       "length follows the path, its velocity is the path's times cos(pennation))"},
      {"muscle_curves", "Thelen 2003 (active force-length, force-velocity, passive)"},
      {"cost",
       "sum a^2 + w sum (reserve / 1 N m)^2, a in [0, 1], reserve = tau_ID - muscle moment"},
      {"reserve_weight_per_Nm2", so_def.params().reserve_weight_per_Nm2},
      {"reserve_weights_per_dof", dof_weights_json(so_def, id.dof_names)},
      {"covered_dofs", so.tau_Nm.cols()},
      {"solve",
       {{"frames_per_second", frames / so.solve_time_s},
        {"solve_time_s", so.solve_time_s},
        {"timed",
         "the per-frame loop only, one thread: state, mj_fwdPosition and mj_fwdVelocity, moment "
         "arms, Hill forces, the QP; not inverse dynamics, set-up or I/O"},
        {"qp_iterations_mean", static_cast<double>(so.qp_iterations) / frames},
        {"qp_failures", so.qp_failures}}},
      {"gait_cycle",
       {{"method",
         "heel strikes per foot: the onset of a force plate's load assigned to that foot where a "
         "plate saw it land, else the back of the sole (heel point) coming down to within 1 cm "
         "of its lowest height in the motion after rising more than 5 cm (interpolated between "
         "frames); a cycle runs from a heel strike to the next of the same foot; cycles whose "
         "stance is on a plate are averaged (all cycles when none is)"},
        {"left", cycles_json(cycles[models::kLeft])},
        {"right", cycles_json(cycles[models::kRight])}}},
      {"dofs", dofs_json(so, so_def.set(), id.dof_names, id.times_s, cycles)},
      {"muscles", muscles_json(so, so_def.set(), id.times_s, cycles)}};
}

/// The console lines: frames and speed, the worst reserve, where the files are.
void print_so(const SoOptions& o, const json& summary) {
  std::string worst;
  double worst_ratio = -1;
  for (const auto& [dof, j] : summary["dofs"].items()) {
    const json& r = j["reserve_to_peak_ratio"];
    if (r.is_number() && r.get<double>() > worst_ratio) worst_ratio = r.get<double>(), worst = dof;
  }
  std::cout << "mocap so: " << summary["frames"] << " frames, "
            << summary["solve"]["frames_per_second"].get<double>()
            << " frames/s (the solve loop), torques from "
            << summary["torques_from"].get<std::string>() << "\n";
  if (!worst.empty()) {
    const json& w = summary["dofs"][worst];
    std::cout << "  largest reserve: " << worst << " " << w["peak_abs_reserve_Nm"] << " N m, "
              << 100.0 * worst_ratio << " % of its peak torque " << w["peak_abs_id_torque_Nm"]
              << " N m\n";
  }
  std::cout << "wrote " << o.output
            << "/{activations.csv, forces.csv, reserves.csv, summary.json, activations.png}\n";
}

/// The muscles' parameters: the anatomy's (Rajagopal 2016 scaled), then --muscle-params.
std::vector<muscles::MuscleParams> so_muscle_params(const models::Character& character,
                                                    const std::string& path,
                                                    std::vector<std::string>* notes) {
  std::vector<muscles::MuscleParams> params =
      muscles::muscle_params(character.muscles, muscles::TendonChoice::kAllRigid);
  if (path.empty()) return params;
  muscles::apply_muscle_overrides(read_file(path), path, &params);
  for (const muscles::MuscleParams& p : params) {
    if (p.tendon == muscles::TendonModel::kCompliant) {
      notes->push_back(path + " makes " + p.name +
                       "'s tendon compliant: static optimisation treats every tendon as rigid");
    }
  }
  return params;
}

int run_so(SoOptions o) {
  check_outputs({{"-o", o.output, true}}, {o.motion, o.settings.c3d, o.muscle_params, o.id_dir});
  if (!(o.reserve_weight > 0 && std::isfinite(o.reserve_weight))) {
    throw sim::InvalidArgument("--reserve-weight: must be > 0, got " +
                               std::to_string(o.reserve_weight));
  }
  if (!o.id_dir.empty() && !std::filesystem::is_directory(o.id_dir)) {
    throw sim::InvalidArgument("--id: '" + o.id_dir +
                               "' is not a directory (give the -o directory of mocap id)");
  }
  // Without plates the ground forces are estimated from the kinematics: with none, every leg
  // joint would carry the body as if it hung in the air.
  o.settings.grf = o.settings.c3d.empty() ? "estimate" : "from-c3d";
  const IdGround ground = o.id_dir.empty() ? id_ground(o.settings) : IdGround{};
  const mocap_io::Motion all = mocap_io::read_motion_csv(o.motion);
  std::vector<std::string> notes;
  models::CharacterSpec spec = o.character.spec_for_motion(o.motion, &notes);
  spec.muscles = true;
  const models::Character character = models::generate_character(spec);
  const sim::Model model = sim::Model::from_string(models::to_mjcf(character), "character");
  mocap_io::check_motion_matches(all, *model, o.motion);
  muscles::MuscleSet set(*model, so_muscle_params(character, o.muscle_params, &notes));
  const muscles::StaticOptimizationParams params = so_params(o, *model, set);
  muscles::StaticOptimization so_def(std::move(set), params);
  const SoInputs in = so_inputs(o, ground, *model, all, spec, &notes);
  if (in.ground == "none") {
    notes.push_back(
        "no ground forces: the stance legs' torques lack the ground reaction (it is "
        "in the root residual), so their muscles are not those of walking; give the "
        "capture's force plates with --c3d");
  }
  const mocap_io::InverseDynamicsResult& id = in.run.id;
  ProgressBar bar("mocap so: " + std::to_string(id.times_s.size()) + " frames");
  const muscles::StaticOptimizationResult so = muscles::static_optimization(
      *model, &so_def, id.qpos, id.qvel, in.tau, [&](double f) { bar.update(f); });
  bar.finish();
  SideCycles cycles[2];
  for (int side : {models::kLeft, models::kRight})
    cycles[side] = side_cycles(*model, in.run, so, so_def.set(), side);
  json summary = so_summary(o, in, so_def, so, spec, cycles);
  summary["notes"] = notes;
  // Every text first, then the plot (gnuplot may fail), then the files.
  std::vector<std::string> names, descriptions, dofs;
  for (const muscles::MuscleParams& p : so_def.set().params()) names.push_back(p.name);
  for (const models::MuscleDefinition& m : character.muscles) descriptions.push_back(m.description);
  for (int dof : so_def.set().covered_dofs())
    dofs.push_back(id.dof_names[static_cast<std::size_t>(dof)]);
  const std::string activations = matrix_csv(id.times_s, names, so.activation);
  const std::string forces = matrix_csv(id.times_s, names, so.force_N);
  const std::string reserves = reserves_csv(id.times_s, dofs, so);
  const std::string summary_text = json_text(summary, 1) + "\n";
  const SideCycles& right = cycles[models::kRight];
  if (right.profile.size() == 0) {
    throw sim::InvalidArgument(o.motion +
                               ": no full gait cycle of the right leg (two right heel "
                               "strikes) in its solved frames: nothing to plot over the cycle");
  }
  std::filesystem::create_directories(o.output);
  plot_activations(o.output, right, cycles[models::kLeft], so_def.set(), descriptions);
  write_file_atomically(o.output + "/activations.csv", activations);
  write_file_atomically(o.output + "/forces.csv", forces);
  write_file_atomically(o.output + "/reserves.csv", reserves);
  write_file_atomically(o.output + "/summary.json", summary_text);
  print_so(o, summary);
  for (const std::string& n : notes) std::cout << "  note: " << n << "\n";
  if (in.ground == "none") {
    std::cerr << "WARNING: no ground forces (give --c3d with the capture's force plates, or --id "
                 "with torques computed with them): the stance legs' muscles are not walking's\n";
  }
  return kExitOk;
}

}  // namespace

Command add_mocap_so_command(CLI::App* mocap) {
  auto so = std::make_shared<SoOptions>();
  CLI::App* cmd = mocap->add_subcommand(
      "so",
      "Static optimisation: a motion's joint torques shared among the legs' Hill muscles "
      "(activations, forces, reserves, activations over the gait cycle)");
  cmd->add_option("--motion", so->motion, "motion CSV (from mocap ik or retarget)")->required();
  so->character.add_to(cmd);
  cmd->add_option("--id", so->id_dir,
                  "the directory mocap id wrote for this motion: its torques.csv (and plates.csv) "
                  "are used; without it inverse dynamics runs here");
  cmd->add_option("--c3d", so->settings.c3d,
                  "without --id: the capture the motion came from; its force plates give the "
                  "ground reaction");
  cmd->add_option("--lab-up", so->settings.lab_up,
                  "without --id: vertical axis of the capture lab (as given to mocap ik): z or y")
      ->capture_default_str();
  cmd->add_option("--cutoff", so->settings.cutoff_hz,
                  "without --id: low-pass cut-off of the positions, Hz (0: no filter)")
      ->capture_default_str();
  cmd->add_option("--muscle-params", so->muscle_params,
                  "muscle parameter JSON ({\"muscles\": {\"soleus\": {\"max_isometric_force_N\": "
                  "5000}}}; see README)");
  cmd->add_option("--reserve-weight", so->reserve_weight,
                  "cost of a squared reserve torque per (N m)^2 against the squared activations")
      ->capture_default_str();
  cmd->add_option("--reserve-weights", so->dof_weights,
                  "per-DOF reserve weights NAME=W,... replacing --reserve-weight there (NAME a "
                  "DOF the muscles span, e.g. hip_r_z, or without its side: hip_z)");
  cmd->add_option("-o,--output", so->output, "output directory")->required();
  return {cmd, [so]() { return run_so(*so); }};
}

}  // namespace biodyn::apps
