#include "cli_common.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <system_error>
#include <thread>

#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/models/body_file.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"
#include "biodyn/sim/log.h"
#include "biodyn/sim/model.h"

namespace biodyn::apps {

std::pair<int, int> parse_size(const std::string& text, const std::string& option) {
  const std::size_t x = text.find('x');
  try {
    if (x == std::string::npos) throw std::invalid_argument("no x");
    std::size_t used = 0;
    const int width = std::stoi(text.substr(0, x), &used);
    if (used != x) throw std::invalid_argument("width");
    const int height = std::stoi(text.substr(x + 1), &used);
    if (used != text.size() - x - 1) throw std::invalid_argument("height");
    return {width, height};
  } catch (const std::logic_error&) {
    throw sim::InvalidArgument(option + ": expected WIDTHxHEIGHT, e.g. 1280x720, got '" + text +
                               "'");
  }
}

std::vector<double> parse_number_list(const std::string& text, const std::string& option,
                                      const std::string& expected) {
  std::vector<double> out;
  // A trailing comma gives an empty last item: refused like any other item that is no number.
  for (const std::string& part : sim::split_fields(text)) {
    try {
      std::size_t used = 0;
      out.push_back(std::stod(part, &used));
      if (used != part.size()) throw std::invalid_argument(part);
    } catch (const std::exception&) {
      throw sim::InvalidArgument(option + ": expected " + expected + ", got '" + text + "'");
    }
  }
  return out;
}

void CharacterOptions::add_to(CLI::App* cmd, bool with_overrides) {
  geometry_options_.push_back(
      cmd->add_option("--height", height_m, "Standing height, m")->capture_default_str());
  mass_option_ = cmd->add_option("--mass", mass_kg, "Body mass, kg")->capture_default_str();
  geometry_options_.push_back(
      cmd->add_option("--sex", sex, "male or female (de Leva 1996 tables)")->capture_default_str());
  geometry_options_.push_back(
      cmd->add_option("--detail", detail,
                      "gait (paper's lower-body model) or full (spine, neck, head, arms)")
          ->capture_default_str());
  if (with_overrides) {
    geometry_options_.push_back(
        cmd->add_option("--overrides", overrides_path,
                        "JSON {\"segments\": {\"thigh\": {\"mass_kg\": 9, \"length_m\": 0.45}}}"));
    geometry_options_.push_back(
        cmd->add_option("--body-file", body_path,
                        "body file (JSON: height, mass, sex, detail, segments, markers), e.g. "
                        "the <motion>.body.json mocap ik writes; --mass may still change the "
                        "mass"));
  }
}

bool CharacterOptions::geometry_given() const {
  return std::any_of(geometry_options_.begin(), geometry_options_.end(),
                     [](const CLI::Option* o) { return o->count() > 0; });
}

models::CharacterSpec CharacterOptions::spec_for_motion(const std::string& motion_path,
                                                        std::vector<std::string>* notes) const {
  const std::optional<models::CharacterSpec> header =
      mocap_io::motion_body(mocap_io::read_motion_csv(motion_path), motion_path);
  if (!header) {
    notes->push_back(motion_path +
                     " does not say which body it was made on (no body header: an older or "
                     "hand-made file); using the body of the command line");
    return to_spec();
  }
  const auto describe = [](const models::CharacterSpec& s) {
    std::ostringstream height;
    height << s.height_m;
    return std::string(models::to_string(s.sex)) + " " + height.str() + " m (" +
           models::to_string(s.detail) + ", " + std::to_string(s.overrides.size()) +
           " segment overrides)";
  };
  if (geometry_given()) {
    const models::CharacterSpec given = to_spec();
    const std::string diff = models::geometry_difference(*header, given);
    if (!diff.empty()) {
      throw sim::InvalidArgument(
          motion_path + " was made on a " + describe(*header) + " body; the body given (" +
          describe(given) + ", unset options at their defaults) differs: " + diff +
          ". Leave out the body options to use the motion's own body (--mass may differ); for "
          "another body, make the motion on it: mocap ik with that body, or mocap retarget "
          "--bvh from the source capture");
    }
    return given;
  }
  models::CharacterSpec spec = *header;
  if (mass_option_ != nullptr && mass_option_->count() > 0 && mass_kg != spec.mass_kg) {
    notes->push_back("the motion's body (" + describe(spec) + ") with --mass " +
                     std::to_string(mass_kg) + " kg instead of its " +
                     std::to_string(spec.mass_kg) + " kg: joint angles hold, forces change");
    spec.mass_kg = mass_kg;
  }
  return spec;
}

models::CharacterSpec CharacterOptions::to_spec() const {
  if (!body_path.empty()) {
    for (const CLI::Option* o : geometry_options_) {
      if (o->count() > 0 && o->get_name() != "--body-file") {
        throw sim::InvalidArgument(
            o->get_name() +
            ": the body file given with --body-file fixes it; give one or the "
            "other");
      }
    }
    models::CharacterSpec spec = models::parse_body_json(read_file(body_path), body_path);
    if (mass_option_ != nullptr && mass_option_->count() > 0) spec.mass_kg = mass_kg;
    return spec;
  }
  models::CharacterSpec spec;
  spec.height_m = height_m;
  spec.mass_kg = mass_kg;
  spec.sex = models::parse_sex(sex, "--sex");
  spec.detail = models::parse_detail(detail, "--detail");
  if (!overrides_path.empty()) {
    spec.overrides = models::parse_overrides(read_file(overrides_path), overrides_path);
    models::check_override_names(spec.overrides, spec.detail, overrides_path);
  }
  return spec;
}

void MuscleOptions::add_to(CLI::App* cmd) {
  cmd->add_option("--muscles", muscles,
                  "on: the legs' Hill muscles (18 per leg, Rajagopal 2016) give the joint "
                  "controllers' torques, with backups where they cannot; off: joint torques")
      ->capture_default_str();
  cmd->add_option("--tendons", tendons,
                  "with --muscles on: default (compliant soleus and gastrocnemius, rigid others), "
                  "rigid or compliant")
      ->capture_default_str();
  cmd->add_option("--muscle-params", params_path,
                  "with --muscles on: muscle parameters (JSON {\"muscles\": {\"soleus\": "
                  "{\"max_isometric_force_N\": 5000}}}; README, Muscles)");
}

scenarios::MuscleConfig MuscleOptions::to_config() const {
  scenarios::MuscleConfig c;
  if (muscles != "on" && muscles != "off")
    throw sim::InvalidArgument("--muscles: must be on or off, got '" + muscles + "'");
  c.on = muscles == "on";
  c.tendons = muscles::parse_tendon_choice(tendons, "--tendons");
  if (!c.on && (tendons != "default" || !params_path.empty()))
    throw sim::InvalidArgument("--tendons/--muscle-params: only with --muscles on");
  if (!params_path.empty()) {
    c.params_json = read_file(params_path);
    c.params_source = params_path;
    // Checked now, against the default body's muscles (names and fields), so a bad file is
    // refused before any work.
    models::CharacterSpec spec;
    spec.detail = models::Detail::kGait;
    spec.muscles = true;
    std::vector<muscles::MuscleParams> params =
        muscles::muscle_params(models::generate_character(spec).muscles, c.tendons);
    muscles::apply_muscle_overrides(c.params_json, c.params_source, &params);
  }
  return c;
}

nlohmann::json muscles_json(const std::optional<scenarios::MuscleRunReport>& report) {
  if (!report) return nullptr;
  nlohmann::json per_joint = nlohmann::json::object();
  for (const scenarios::MuscleJointShare& j : report->joints) {
    per_joint[j.joint] = {{"backup_share", j.backup_share()},
                          {"muscle_share", 1.0 - j.backup_share()},
                          {"muscle_Nms", j.muscle_Nms},
                          {"backup_Nms", j.backup_Nms},
                          {"not_given_Nms", j.not_given_Nms}};
  }
  return {{"muscles", report->muscles},
          {"compliant_tendons", report->compliant_tendons},
          {"rigid_tendons", report->rigid_tendons},
          {"per_joint", per_joint},
          {"share_rule",
           "integrals of |torque| over the run; backup_share = backup / (muscle + backup); "
           "not_given: wanted by the controller, beyond the backups' range"},
          {"qp_failures", report->qp_failures},
          {"fiber_solve_failures", report->fiber_solve_failures}};
}

nlohmann::json joint_load_json(const scenarios::JointLoadReport& r) {
  return {{"stop_peak_Nm", r.stop_peak_Nm},
          {"stop_peak_dof", r.stop_peak_dof},
          {"load_peak_ratio", r.load_peak_ratio},
          {"load_peak_dof", r.load_peak_dof},
          {"load_over_tau_max_s", r.over_s},
          {"load_over_tau_max_longest_s", r.over_longest_s},
          {"load_over_tau_max_longest_dof", r.over_longest_dof},
          {"about",
           "the joints' range stops (rigid MuJoCo limits) are passive structure; load = |motor "
           "+ stop| / tau_max per DOF (motor: every torque applied on the DOF, the ball joints' "
           "swing-twist limits included; damping not counted), toes not judged"}};
}

void print_joint_load(const scenarios::JointLoadReport& r, std::ostream& out) {
  const auto old = out.flags();
  const auto precision = out.precision();
  out << std::fixed << std::setprecision(0) << "  joint stops carried up to " << r.stop_peak_Nm
      << " N m" << (r.stop_peak_dof.empty() ? "" : " (" + r.stop_peak_dof + ")")
      << "; motor (ball joints: with their swing-twist limits) + stop up to "
      << 100 * r.load_peak_ratio << "% of tau_max"
      << (r.load_peak_dof.empty() ? "" : " (" + r.load_peak_dof + ")") << std::setprecision(3)
      << ", above it " << r.over_s << " s (longest " << r.over_longest_s << " s"
      << (r.over_longest_dof.empty() ? "" : ", " + r.over_longest_dof) << ")\n";
  out.flags(old);
  out.precision(precision);
}

void print_muscles(const std::optional<scenarios::MuscleRunReport>& report, std::ostream& out) {
  if (!report) return;
  out << "  muscles:  " << report->muscles.size() << " (" << report->compliant_tendons
      << " compliant tendons); backups' share of the joint torque:";
  for (const scenarios::MuscleJointShare& j : report->joints) {
    char text[64];
    std::snprintf(text, sizeof text, " %s %.0f%%", j.joint.c_str(), 100 * j.backup_share());
    out << text;
  }
  out << "\n";
}

void plot_with_gnuplot(const std::string& command, const std::string& script_path,
                       const std::string& png_tmp, const std::string& png) {
  const std::string cmd = "gnuplot " + script_path + " 2>&1";
  std::string output;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (pipe == nullptr) throw sim::Error(command + ": cannot start gnuplot (install gnuplot-nox)");
  char buffer[256];
  while (fgets(buffer, sizeof buffer, pipe) != nullptr) output += buffer;
  const int status = pclose(pipe);
  if (status != 0 || !std::filesystem::exists(png_tmp)) {
    std::filesystem::remove(png_tmp);
    throw sim::Error(command + ": gnuplot failed on " + script_path + " (exit " +
                     std::to_string(status) + "): " + output);
  }
  std::filesystem::rename(png_tmp, png);
}

void TerrainOptions::add_to(CLI::App* cmd) {
  cmd->add_option("--terrain", kind,
                  "Ground ahead: flat | hill (a ramp up at --terrain-slope, a 3 m plateau, a ramp "
                  "down) | steps (a step up of --terrain-step, a 3 m plateau, a step down)")
      ->capture_default_str();
  cmd->add_option("--terrain-slope", shape.slope_deg, "Hill slope, deg (ramps 4 m long)")
      ->capture_default_str();
  cmd->add_option("--terrain-step", shape.step_m, "Step height, m")->capture_default_str();
  cmd->add_option("--terrain-start", shape.start_m,
                  "Where the terrain begins, m ahead of the start (walking straight on)")
      ->capture_default_str();
}

models::Terrain TerrainOptions::to_terrain() const {
  models::Terrain t = shape;
  t.kind = models::parse_terrain_kind(kind, "--terrain");
  t.validate();
  return t;
}

std::string TerrainOptions::text() const {
  std::ostringstream s;
  if (kind == "hill") {
    s << ", terrain: from " << shape.start_m << " m a " << shape.ramp_m << " m ramp up at "
      << shape.slope_deg << " deg, a " << shape.plateau_m << " m plateau, a ramp down";
  } else if (kind == "steps") {
    s << ", terrain: from " << shape.start_m << " m a " << 100 * shape.step_m << " cm step up, a "
      << shape.plateau_m << " m plateau, a step down";
  }
  return s.str();
}

std::string TerrainOptions::args() const {
  if (kind == "flat") return "";
  std::ostringstream a;
  a << std::setprecision(6) << " --terrain " << kind << " --terrain-slope " << shape.slope_deg
    << " --terrain-step " << shape.step_m << " --terrain-start " << shape.start_m;
  return a.str();
}

nlohmann::json TerrainOptions::json() const {
  if (kind == "flat") return nullptr;
  return {{"kind", kind},           {"start_m", shape.start_m}, {"slope_deg", shape.slope_deg},
          {"ramp_m", shape.ramp_m}, {"step_m", shape.step_m},   {"plateau_m", shape.plateau_m}};
}

namespace {

// The workers of run_batch and run_jobs: make_worker() once per worker (its own state), then that
// worker's job for the next index until none is left.
void run_workers(std::size_t count, int threads, const std::string& label,
                 const std::function<std::function<void(std::size_t)>()>& make_worker) {
  std::atomic<std::size_t> next{0}, done{0};
  std::mutex mutex;
  std::string first_error;
  ProgressBar bar(label);
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&]() {
      try {
        const std::function<void(std::size_t)> job = make_worker();
        for (std::size_t i = next++; i < count; i = next++) {
          job(i);
          const std::size_t n = ++done;
          std::lock_guard<std::mutex> lock(mutex);
          bar.update(static_cast<double>(n) / static_cast<double>(count));
        }
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(mutex);
        if (first_error.empty()) first_error = e.what();
        next = count;
      }
    });
  }
  for (std::thread& w : workers) w.join();
  if (!first_error.empty()) throw sim::Error(label + ": " + first_error);
}

}  // namespace

void run_batch(std::size_t count, int threads, const std::string& mjcf, const std::string& label,
               const std::function<void(sim::Simulation*, std::size_t)>& job) {
  run_workers(count, threads, label, [&]() -> std::function<void(std::size_t)> {
    // this worker's copy
    auto sim = std::make_shared<sim::Simulation>(sim::Model::from_string(mjcf, "<character>"));
    return [sim, &job](std::size_t i) { job(sim.get(), i); };
  });
}

void run_jobs(std::size_t count, int threads, const std::string& label,
              const std::function<void(std::size_t)>& job) {
  run_workers(count, threads, label, [&job]() { return job; });
}

int batch_threads(int requested, std::size_t jobs) {
  const int threads = requested > 0
                          ? requested
                          : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  return static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(threads), jobs));
}

void install_console_log(bool verbose) {
  sim::set_log_sink([verbose](sim::LogLevel level, std::string_view msg) {
    if (!verbose && (level == sim::LogLevel::kDebug || level == sim::LogLevel::kInfo)) return;
    std::cerr << "biodyn: " << sim::to_string(level) << ": " << msg << "\n";
  });
}

nlohmann::json character_json(const models::CharacterSpec& spec) {
  return {{"height_m", spec.height_m},
          {"mass_kg", spec.mass_kg},
          {"sex", models::to_string(spec.sex)},
          {"detail", models::to_string(spec.detail)}};
}

}  // namespace biodyn::apps

#include <unistd.h>

namespace biodyn::apps {

ProgressBar::ProgressBar(std::string label) : label_(std::move(label)), tty_(isatty(2) != 0) {}

void ProgressBar::update(double fraction) {
  constexpr int kWidth = 30;
  const int percent = static_cast<int>(std::clamp(fraction, 0.0, 1.0) * 100.0);
  if (percent == last_percent_ || done_) return;
  last_percent_ = percent;
  if (!tty_) return;
  const int filled = percent * kWidth / 100;
  std::cerr << "\r" << label_ << " [" << std::string(static_cast<size_t>(filled), '#')
            << std::string(static_cast<size_t>(kWidth - filled), '.') << "] " << percent << "%"
            << std::flush;
}

ProgressBar::~ProgressBar() {
  if (std::uncaught_exceptions() == 0) {
    finish();
  } else if (tty_ && last_percent_ >= 0 && !done_) {
    std::cerr << "\n";
  }
}

void ProgressBar::finish() {
  if (done_) return;
  done_ = true;
  if (tty_) {
    std::cerr << "\r" << label_ << " [" << std::string(30, '#') << "] 100%\n";
  } else {
    std::cerr << label_ << ": done\n";
  }
}

void check_outputs(const std::vector<OutputPath>& outputs, const std::vector<std::string>& inputs) {
  namespace fs = std::filesystem;
  std::error_code ec;
  auto same = [&](const std::string& a, const std::string& b) {
    return fs::weakly_canonical(a, ec) == fs::weakly_canonical(b, ec);
  };
  for (size_t i = 0; i < outputs.size(); ++i) {
    const OutputPath& o = outputs[i];
    if (o.path.empty()) continue;
    const fs::path p(o.path);
    if (o.directory) {
      if (fs::exists(p, ec) && !fs::is_directory(p, ec)) {
        throw sim::InvalidArgument(o.option + ": '" + o.path + "' is a file, not a directory");
      }
    } else if (fs::is_directory(p, ec)) {
      throw sim::InvalidArgument(o.option + ": '" + o.path + "' is a directory, not a file");
    }
    // The nearest existing ancestor must be a directory (the rest is created).
    for (fs::path up = p.parent_path(); !up.empty(); up = up.parent_path()) {
      if (!fs::exists(up, ec)) continue;
      if (!fs::is_directory(up, ec)) {
        throw sim::InvalidArgument(o.option + ": '" + o.path + "': '" + up.string() +
                                   "' is a file, not a directory");
      }
      break;
    }
    for (const std::string& in : inputs) {
      if (!in.empty() && same(o.path, in)) {
        throw sim::InvalidArgument(o.option + ": '" + o.path +
                                   "' is an input; inputs are never "
                                   "overwritten");
      }
    }
    for (size_t k = 0; k < i; ++k) {
      if (!outputs[k].path.empty() && same(o.path, outputs[k].path)) {
        throw sim::InvalidArgument(o.option + " and " + outputs[k].option + ": both '" + o.path +
                                   "'");
      }
    }
  }
}

}  // namespace biodyn::apps
