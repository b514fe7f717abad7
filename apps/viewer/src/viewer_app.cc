// The interactive viewer (viewer_app.h): GLFW window, MuJoCo renderer, Dear ImGui panels,
// physics on its own thread.
#include "biodyn/viewer/viewer_app.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui/backends/imgui_impl_glfw.h>
#include <imgui/backends/imgui_impl_opengl3.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <thread>

#include "biodyn/controllers/support_polygon.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/renderer.h"
#include "biodyn/sim/units.h"
#include "biodyn/viewer/headless_gl.h"
#include "biodyn/viewer/image_output.h"
#include "biodyn/viewer/overlays.h"
#include "muscle_plots.h"

namespace biodyn::viewer {
namespace {

using Clock = std::chrono::steady_clock;
/// Ctrl + drag pushes: N of force per pixel dragged (a 100-pixel drag is 200 N).
constexpr double kDragNewtonsPerPixel = 2.0;

// ---------------------------------------------------------------------------------------------
// Script
// ---------------------------------------------------------------------------------------------

struct ScriptCommand {
  double t = 0;
  int line = 0;
  std::vector<std::string> words;  // the command and its arguments
};

std::vector<ScriptCommand> parse_script(const std::string& path) {
  std::istringstream in(sim::read_file(path));  // bounded: no device, fifo or huge file
  std::vector<ScriptCommand> out;
  std::string text;
  for (int line = 1; std::getline(in, text); ++line) {
    text = text.substr(0, text.find('#'));
    std::istringstream words(text);
    std::vector<std::string> w;
    for (std::string s; words >> s;) w.push_back(s);
    if (w.empty()) continue;
    const auto fail = [&](const std::string& rule) {
      throw sim::InvalidArgument(path + ":" + std::to_string(line) + ": " + rule + ", got '" +
                                 text + "'");
    };
    if (w.size() < 3 || w[0] != "at") fail("expected 'at <time> <command> ...'");
    ScriptCommand c;
    c.line = line;
    try {
      std::size_t used = 0;
      c.t = std::stod(w[1], &used);
      if (used != w[1].size() || !(c.t >= 0)) throw std::invalid_argument("t");
    } catch (const std::logic_error&) {
      fail("the time must be a number >= 0 s");
    }
    c.words.assign(w.begin() + 2, w.end());
    const std::string& cmd = c.words[0];
    const std::size_t n = c.words.size();
    const bool ok = (cmd == "set" && (n == 3 || (n == 4 && c.words[1] == "tau_scale"))) ||
                    (cmd == "push" && n == 5) || (cmd == "save-params" && n == 3) ||
                    (cmd == "screenshot" && n == 2) || (cmd == "rewind" && n == 2) ||
                    (cmd == "quit" && n == 1);
    if (!ok) {
      fail(
          "expected set <field> <value>, set tau_scale <group> <factor>, push <body> <N> <deg> "
          "<s>, save-params <walker.json> <controller.json>, screenshot <file.png>, rewind <s> "
          "or quit");
    }
    out.push_back(c);
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const ScriptCommand& a, const ScriptCommand& b) { return a.t < b.t; });
  return out;
}

double number(const std::string& s, const std::string& what) {
  try {
    std::size_t used = 0;
    const double v = std::stod(s, &used);
    if (used == s.size() && std::isfinite(v)) return v;
  } catch (const std::logic_error&) {
  }
  throw sim::InvalidArgument(what + ": expected a number, got '" + s + "'");
}

// ---------------------------------------------------------------------------------------------
// Shared state between the threads
// ---------------------------------------------------------------------------------------------

/// The last ~12 s of states, for scrubbing back (display) and the step to rewind to.
struct History {
  static constexpr int kEvery = 5;  // steps between entries (10 ms at 2 ms)
  std::vector<long> step;
  std::vector<double> time;
  std::vector<std::vector<double>> qpos;
  std::vector<std::vector<float>> activation;  // the muscles' (empty without muscles)
  int head = 0, count = 0;
  double entry_s = 0.01;  // simulated seconds between entries
  void init(int capacity, int nq, int muscles, double timestep_s) {
    entry_s = kEvery * timestep_s;
    step.assign(static_cast<std::size_t>(capacity), 0);
    time.assign(static_cast<std::size_t>(capacity), 0);
    qpos.assign(static_cast<std::size_t>(capacity),
                std::vector<double>(static_cast<std::size_t>(nq)));
    activation.assign(static_cast<std::size_t>(capacity),
                      std::vector<float>(static_cast<std::size_t>(muscles)));
  }
  int capacity() const { return static_cast<int>(step.size()); }
  void add(long s, double t, const double* q, const muscles::MuscleDrive* drive) {
    const std::size_t i = static_cast<std::size_t>(head);
    step[i] = s;
    time[i] = t;
    std::copy(q, q + qpos[i].size(), qpos[i].begin());
    if (drive != nullptr) {
      const std::vector<double>& a = drive->state().activation;
      std::transform(a.begin(), a.begin() + static_cast<long>(activation[i].size()),
                     activation[i].begin(), [](double v) { return static_cast<float>(v); });
    }
    head = (head + 1) % capacity();
    count = std::min(count + 1, capacity());
  }
  /// Index of the entry `back` entries before the newest (0 = newest).
  int at(int back) const { return ((head - 1 - back) % capacity() + capacity()) % capacity(); }
  /// Drops entries newer than step s.
  void truncate_after(long s) {
    while (count > 0 && step[static_cast<std::size_t>(at(0))] > s) {
      head = (head - 1 + capacity()) % capacity();
      --count;
    }
  }
  double span_s() const {
    return count < 2 ? 0.0
                     : time[static_cast<std::size_t>(at(0))] -
                           time[static_cast<std::size_t>(at(count - 1))];
  }
};

/// Scrolling plot samples (10 s at 50 Hz).
struct Plots {
  static constexpr int kSamples = 500;
  static constexpr int kEvery = 10;  // steps between samples (20 ms)
  std::vector<std::string> groups;   // plotted joint groups
  std::vector<int> group_index;
  std::array<float, kSamples> com_outside{}, tolerance_outside{}, speed{}, contact_l{}, contact_r{};
  std::vector<std::array<float, kSamples>> torque_ratio;
  int head = 0;
  void push(float com, float tol, float v, float cl, float cr, const std::vector<float>& ratios) {
    com_outside[static_cast<std::size_t>(head)] = com;
    tolerance_outside[static_cast<std::size_t>(head)] = tol;
    speed[static_cast<std::size_t>(head)] = v;
    contact_l[static_cast<std::size_t>(head)] = cl;
    contact_r[static_cast<std::size_t>(head)] = cr;
    for (std::size_t g = 0; g < torque_ratio.size(); ++g)
      torque_ratio[g][static_cast<std::size_t>(head)] = ratios[g];
    head = (head + 1) % kSamples;
  }
};

struct Shared {
  std::mutex mutex;
  scenarios::LiveScenario* scenario = nullptr;
  bool paused = false;
  int single_steps = 0;
  double speed_factor = 1.0;  // simulated seconds per wall second
  double scrub_s = 0.0;       // <= 0: how far back the display is (paused)
  bool quit = false;
  std::string message;  // one line shown in the status bar
  History history;
  Plots plots;
  MusclePlots muscle_plots;        // --muscles on: activations and the muscles' torque shares
  OverlayBuffers overlay_buffers;  // the render thread's (under the lock)
  OverlayBuffers plot_buffers;     // the physics thread's plot samples
  std::vector<float> ratio_scratch;
  // The script runs on the physics thread, at its exact steps (a scripted session is as
  // deterministic as a headless run); screenshots are taken by the render thread while the
  // physics waits.
  const std::vector<ScriptCommand>* script = nullptr;
  std::string script_path;
  std::size_t next_command = 0;
  std::string screenshot_path;  // asked for, not yet taken
  bool screenshot_requested = false;
  std::string script_error;  // set by the physics thread; thrown by run_viewer
  // Measured by the physics thread.
  long steps_run = 0;
  double running_wall_s = 0, running_sim_s = 0;
};

void sample_plots(Shared& sh) {
  scenarios::LiveScenario& s = *sh.scenario;
  const mjModel& m = s.simulation().model();
  const mjData& d = s.simulation().data();
  OverlayBuffers& b = sh.plot_buffers;
  foot_support(m, d, s.rig(), &b);
  const models::RigLeg& left = s.rig().leg(models::kLeft);
  const models::RigLeg& right = s.rig().leg(models::kRight);
  const sim::CenterOfMass com = sim::center_of_mass(m, d);
  const Eigen::Vector2d c = com.position_W.head<2>();
  const float outside = static_cast<float>(controllers::distance_outside(b.hull, c));
  const float tol =
      s.gait() ? static_cast<float>(controllers::distance_outside(s.gait()->tolerance_polygon(), c))
               : 0.0f;
  bool on[2] = {false, false};
  for (const sim::FloorContact& k : b.contacts) {
    if (k.body == left.foot || k.body == left.toes) on[0] = true;
    if (k.body == right.foot || k.body == right.toes) on[1] = true;
  }
  sh.ratio_scratch.assign(sh.plots.group_index.size(), 0.0f);
  const controllers::ControlPipeline* pipeline = s.controller();  // none in a kinematic playback
  for (std::size_t g = 0; pipeline != nullptr && g < sh.plots.group_index.size(); ++g) {
    const auto& tau = pipeline->joints().previous_torque();
    const auto& tau_max = pipeline->joints().tau_max();
    const controllers::JointGroup& jg =
        s.rig().groups()[static_cast<std::size_t>(sh.plots.group_index[g])];
    for (int k = 0; k < jg.dof_count; ++k) {
      const std::size_t dof = static_cast<std::size_t>(jg.dof_begin + k);
      if (tau_max[dof] > 0)
        sh.ratio_scratch[g] =
            std::max(sh.ratio_scratch[g], static_cast<float>(std::abs(tau[dof]) / tau_max[dof]));
    }
  }
  sh.plots.push(outside, tol, static_cast<float>(com.velocity_W.head<2>().norm()),
                on[0] ? 1.0f : 0.0f, on[1] ? 1.0f : 0.0f, sh.ratio_scratch);
  sh.muscle_plots.sample(s);
}

void run_command(Shared& sh, const ScriptCommand& c, const std::string& script);

// The controller parameters in use; throws sim::InvalidArgument for a kinematic playback.
controllers::ControllerParams current_controller_params(const scenarios::LiveScenario& s) {
  const controllers::ControllerParams* p = s.controller_params();
  if (p == nullptr)
    throw sim::InvalidArgument(
        "controller parameters: the motion plays kinematically, no controllers");
  return *p;
}

/// The physics thread: keeps simulated time at speed_factor x wall time (dropping behind rather
/// than spiralling when the machine cannot keep up), records history and plot samples.
void physics_loop(Shared& sh) {
  auto last = Clock::now();
  double target = -1;
  while (true) {
    {
      std::unique_lock<std::mutex> lock(sh.mutex);
      if (sh.quit) return;
      scenarios::LiveScenario& s = *sh.scenario;
      const auto now = Clock::now();
      const double wall_dt = std::chrono::duration<double>(now - last).count();
      last = now;
      // Script commands due at this step; false while a screenshot is waiting to be taken (the
      // commands after it wait too: a quit at the screenshot's time comes after it).
      const auto run_script = [&] {
        while (sh.script != nullptr && sh.next_command < sh.script->size() &&
               s.time_s() >= (*sh.script)[sh.next_command].t - 1e-9 && !sh.quit &&
               !sh.screenshot_requested) {
          try {
            run_command(sh, (*sh.script)[sh.next_command++], sh.script_path);
          } catch (const std::exception& e) {
            // A command the scenario refuses (an unknown walker field, a bad value): the session
            // ends and run_viewer reports it, rather than going on without it.
            sh.script_error = e.what();
            sh.quit = true;
          }
          if (sh.screenshot_requested) return false;
        }
        return !sh.quit && !sh.screenshot_requested;
      };
      if (!run_script()) {
        last = now;
        target = -1;
        goto idle;
      }
      {
        const auto step_once = [&] {
          s.step();
          ++sh.steps_run;
          if (s.step_index() % History::kEvery == 0) {
            sh.history.add(s.step_index(), s.time_s(), s.simulation().data().qpos, s.muscles());
          }
          if (s.step_index() % Plots::kEvery == 0) sample_plots(sh);
        };
        const bool scrubbed = sh.scrub_s < 0;
        if ((!sh.paused || sh.single_steps > 0) && scrubbed) {
          // Resuming from a point in the past: the scenario replays to it (exact, live.h).
          const int back =
              std::clamp(static_cast<int>(std::lround(-sh.scrub_s / sh.history.entry_s)), 0,
                         sh.history.count - 1);
          const long to = sh.history.step[static_cast<std::size_t>(sh.history.at(back))];
          s.rewind_to(to);
          sh.history.truncate_after(to);
          sh.scrub_s = 0;
          target = -1;
        }
        if (sh.single_steps > 0) {
          step_once();
          --sh.single_steps;
          target = -1;
        } else if (!sh.paused) {
          if (target < 0) target = s.time_s();
          target += wall_dt * sh.speed_factor;
          const auto budget_end = now + std::chrono::milliseconds(30);
          const double t_start = s.time_s();
          while (s.time_s() < target && Clock::now() < budget_end) {
            step_once();
            if (!run_script()) break;
          }
          if (s.time_s() < target - 0.1) target = s.time_s();  // behind: slow down, never spiral
          sh.running_wall_s += wall_dt;
          sh.running_sim_s += s.time_s() - t_start;
        } else {
          target = -1;
        }
      }
    }
  idle:
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

// ---------------------------------------------------------------------------------------------
// Edits (panels and script share them)
// ---------------------------------------------------------------------------------------------

void set_walker_field(scenarios::LiveScenario& s, const std::string& field, double value) {
  if (s.gait() == nullptr)
    throw sim::InvalidArgument("walker." + field + ": the scenario does not walk");
  controllers::TorqueWalkerParams p = s.gait()->params();
  controllers::apply_torque_walker_json(nlohmann::json{{field, value}}.dump(), "walker", &p);
  s.set_gait_params(p);
}

void push_relative(scenarios::LiveScenario& s, const std::string& body, double force_N,
                   double direction_deg, double duration_s) {
  const double heading = s.gait() ? s.gait()->heading_rad() : 0.0;
  const double a = heading + direction_deg * kPi / 180.0;
  s.push(body, force_N * Eigen::Vector3d(std::cos(a), std::sin(a), 0), duration_s);
}

void save_params(const scenarios::LiveScenario& s, const std::string& walker_path,
                 const std::string& controller_path) {
  if (!walker_path.empty() && s.gait() != nullptr) {
    sim::write_file_atomically(walker_path, s.gait_params_json());
  }
  if (!controller_path.empty())
    sim::write_file_atomically(controller_path, s.controller_params_json());
}

/// Runs one script command (physics lock held).
void run_command(Shared& sh, const ScriptCommand& c, const std::string& script) {
  scenarios::LiveScenario& s = *sh.scenario;
  const std::vector<std::string>& w = c.words;
  const std::string where = script + ":" + std::to_string(c.line);
  try {
    if (w[0] == "set") {
      if (w[1] == "speed") {
        s.set_speed(number(w[2], "speed"));
      } else if (w[1] == "heading_rate") {
        s.set_heading_rate(number(w[2], "heading_rate"));
      } else if (w[1] == "weld") {
        s.set_weld_mode(controllers::parse_weld_mode(w[2], "weld"));
      } else if (w[1] == "controller") {
        s.set_walker_actuation(controllers::parse_walker_actuation(w[2], "controller"));
      } else if (w[1].rfind("walker.", 0) == 0) {
        set_walker_field(s, w[1].substr(7), number(w[2], w[1]));
      } else if (w[1] == "reaction_time") {
        controllers::ControllerParams p = current_controller_params(s);
        for (controllers::JointParams& j : p.joints) j.reaction_time_s = number(w[2], w[1]);
        s.set_controller_params(p);
      } else if (w[1] == "tau_scale") {
        controllers::ControllerParams p = current_controller_params(s);
        p.at(w[2]).tau_max_Nm *= number(w[3], "tau_scale");
        s.set_controller_params(p);
      } else {
        throw sim::InvalidArgument("unknown field '" + w[1] + "'");
      }
    } else if (w[0] == "push") {
      push_relative(s, w[1], number(w[2], "force"), number(w[3], "direction"),
                    number(w[4], "duration"));
    } else if (w[0] == "save-params") {
      save_params(s, w[1], w[2]);
    } else if (w[0] == "screenshot") {
      sh.screenshot_requested = true;
      sh.screenshot_path = w[1];
    } else if (w[0] == "rewind") {
      sh.scrub_s = -number(w[1], "rewind");
    } else if (w[0] == "quit") {
      sh.quit = true;
    }
  } catch (const sim::InvalidArgument& e) {
    throw sim::InvalidArgument(where + ": " + e.what());
  }
}

// ---------------------------------------------------------------------------------------------
// Panels
// ---------------------------------------------------------------------------------------------

struct UiState {
  float push_force_N = 200, push_direction_deg = 90, push_duration_s = 0.2f;
  int push_body = 0;
  char walker_path[256] = "walker_params.json";
  char controller_path[256] = "controller_params.json";
  bool follow = true;
  OverlayOptions overlays;
  int muscle_leg = models::kLeft;  // whose muscles the plots show
};

void simulation_panel(Shared& sh, UiState& ui, double fps, double sim_rate) {
  scenarios::LiveScenario& s = *sh.scenario;
  // First layout: simulation top left, controllers below it, plots on the right.
  ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(400, 290), ImGuiCond_FirstUseEver);
  ImGui::Begin("Simulation");
  ImGui::Text("t = %.2f s   %s", s.time_s(), s.fallen() ? "FALLEN" : "");
  ImGui::Text("%.0f frames/s, physics %.2fx real time", fps, sim_rate);
  if (ImGui::Button(sh.paused ? "Run (space)" : "Pause (space)")) sh.paused = !sh.paused;
  ImGui::SameLine();
  if (ImGui::Button("Step (.)")) sh.single_steps += 1;
  ImGui::SameLine();
  if (ImGui::Button("Reset (backspace)")) {
    s.reset();
    sh.history.count = 0;
    sh.scrub_s = 0;
  }
  float log2_speed = static_cast<float>(std::log2(sh.speed_factor));
  if (ImGui::SliderFloat("speed (log2)", &log2_speed, -4.0f, 2.0f, "%.1f")) {
    sh.speed_factor = std::pow(2.0, std::round(log2_speed));
  }
  ImGui::SameLine();
  ImGui::Text("%gx", sh.speed_factor);
  float scrub = static_cast<float>(sh.scrub_s);
  const float span = static_cast<float>(sh.history.span_s());
  if (ImGui::SliderFloat("rewind (s)", &scrub, -span, 0.0f, "%.2f")) {
    sh.paused = true;
    sh.scrub_s = scrub;
  }
  ImGui::Checkbox("camera follows", &ui.follow);
  ImGui::Separator();
  ImGui::Text("Overlays");
  ImGui::Checkbox("support polygon", &ui.overlays.support_polygon);
  ImGui::SameLine();
  ImGui::Checkbox("tolerance polygon", &ui.overlays.tolerance_polygon);
  ImGui::Checkbox("CoM projection", &ui.overlays.com_projection);
  ImGui::SameLine();
  ImGui::Checkbox("contact forces", &ui.overlays.contact_forces);
  ImGui::Checkbox("pushes", &ui.overlays.pushes);
  ImGui::SameLine();
  ImGui::Checkbox("welds", &ui.overlays.welds);
  if (s.muscles() != nullptr) {
    ImGui::Checkbox("muscles (by activation)", &ui.overlays.muscles);
    ImGui::SameLine();
    ImGui::Checkbox("wrapping cylinders", &ui.overlays.wrap_cylinders);
  }
  if (s.tracker() != nullptr) {
    // Tracked playback: how far the body is from the motion (motion_tracker.h).
    const controllers::MotionTracker::Error e = s.tracking_error();
    ImGui::Separator();
    ImGui::Text("Tracking (%s): joints %.1f deg off now, RMS %.1f deg",
                s.config().tracker.balance ? "balance feedback" : "open loop",
                e.joint_rms_rad * kDegPerRad, s.tracking_stats().joint_rms_rad() * kDegPerRad);
    ImGui::Text("pelvis %.2f m from the motion's", e.root_horizontal_m);
    if (s.time_s() > s.motion_length_s())
      ImGui::Text("motion over at %.2f s: holding its last frame", s.motion_length_s());
    if (s.fell_at_s() >= 0)
      ImGui::TextColored(ImVec4(1.0f, 0.5f, 0.3f, 1), "fell at %.2f s", s.fell_at_s());
  }
  if (s.config().scenario == "stones") {
    ImGui::SameLine();
    ImGui::Checkbox("stones", &ui.overlays.stones);
    // The plan and how each step came out (green within 2 cm, as drawn).
    ImGui::Separator();
    ImGui::Text("Stepping stones from %.1f s", s.config().steps_start_s);
    const auto& stones = s.stones();
    for (std::size_t i = 0; i < s.config().steps_m.size(); ++i) {
      const double target = s.config().steps_m[i];
      if (i < stones.size() && !std::isnan(stones[i].walked_m)) {
        const double err = stones[i].walked_m - target;
        ImGui::TextColored(
            std::abs(err) <= 0.02 ? ImVec4(0.4f, 0.9f, 0.5f, 1) : ImVec4(1.0f, 0.6f, 0.2f, 1),
            "%zu: %.2f m  walked %.3f m  (%+.1f cm)", i + 1, target, stones[i].walked_m, 100 * err);
      } else {
        ImGui::Text("%zu: %.2f m  %s", i + 1, target, i < stones.size() ? "in swing" : "");
      }
    }
  }
  ImGui::End();
}

// The torque walker's state machine: each phase's targets, the lean and the balance tolerance.
void gait_section(scenarios::LiveScenario& s) {
  if (ImGui::CollapsingHeader("Gait state machine", ImGuiTreeNodeFlags_DefaultOpen)) {
    controllers::TorqueWalkerParams p = s.gait()->params();
    bool changed = false;
    for (std::size_t i = 0; i < p.phases.size(); ++i) {
      controllers::TorqueWalkerPhase& st = p.phases[i];
      ImGui::PushID(static_cast<int>(i));
      ImGui::Text("%s%s", st.name.c_str(), st.ends_at_strike ? " (ends at strike)" : "");
      float dur = static_cast<float>(st.duration_s);
      if (!st.ends_at_strike && ImGui::SliderFloat("duration (s)", &dur, 0.05f, 1.0f)) {
        st.duration_s = dur;
        changed = true;
      }
      const auto angle = [&](const char* label, double* rad) {
        float deg = static_cast<float>(*rad * kDegPerRad);
        if (ImGui::SliderFloat(label, &deg, -90.0f, 120.0f, "%.1f deg")) {
          *rad = deg * kRadPerDeg;
          changed = true;
        }
      };
      angle("swing hip", &st.swing_hip_rad);
      angle("swing knee", &st.swing_knee_rad);
      angle("swing ankle", &st.swing_ankle_rad);
      angle("stance knee", &st.stance_knee_rad);
      angle("stance ankle", &st.stance_ankle_rad);
      ImGui::PopID();
    }
    float lean = static_cast<float>(p.pelvis_pitch_rad * kDegPerRad);
    if (ImGui::SliderFloat("pelvis lean", &lean, -10.0f, 30.0f, "%.1f deg")) {
      p.pelvis_pitch_rad = lean * kRadPerDeg;
      changed = true;
    }
    float tol = static_cast<float>(p.tolerance_fraction);
    if (ImGui::SliderFloat("balance tolerance", &tol, 0.0f, 0.5f)) {
      p.tolerance_fraction = tol;
      changed = true;
    }
    if (changed) s.set_gait_params(p);
  }
}

// Each joint group's torque bound, reaction time and reach time (the controller's parameters).
void joint_groups_section(scenarios::LiveScenario& s) {
  if (ImGui::CollapsingHeader("Joint groups")) {
    controllers::ControllerParams p = current_controller_params(s);
    bool changed = false;
    if (ImGui::BeginTable("groups", 4, ImGuiTableFlags_RowBg | ImGuiTableFlags_SizingStretchProp)) {
      ImGui::TableSetupColumn("group");
      ImGui::TableSetupColumn("tau_max (N m)");
      ImGui::TableSetupColumn("reaction (ms)");
      ImGui::TableSetupColumn("reach (s)");
      ImGui::TableHeadersRow();
      for (std::size_t g = 0; g < p.joints.size(); ++g) {
        controllers::JointParams& j = p.joints[g];
        ImGui::PushID(static_cast<int>(g));
        ImGui::TableNextRow();
        ImGui::TableNextColumn();
        ImGui::TextUnformatted(p.names[g].c_str());
        ImGui::TableNextColumn();
        float tau = static_cast<float>(j.tau_max_Nm.x());
        if (ImGui::DragFloat("##tau", &tau, 1.0f, 1.0f, 1000.0f, "%.0f")) {
          j.tau_max_Nm *= tau / std::max(j.tau_max_Nm.x(), 1e-9);
          changed = true;
        }
        ImGui::TableNextColumn();
        float tr = static_cast<float>(j.reaction_time_s * 1000);
        if (ImGui::DragFloat("##tr", &tr, 0.5f, 2.0f, 500.0f, "%.0f")) {
          j.reaction_time_s = tr / 1000.0;
          changed = true;
        }
        ImGui::TableNextColumn();
        float reach = static_cast<float>(j.reach_time_s);
        if (ImGui::DragFloat("##reach", &reach, 0.01f, 0.02f, 3.0f, "%.2f")) {
          j.reach_time_s = reach;
          changed = true;
        }
        ImGui::PopID();
      }
      ImGui::EndTable();
    }
    if (changed) s.set_controller_params(p);
  }
}

void push_section(scenarios::LiveScenario& s, UiState& ui) {
  if (ImGui::CollapsingHeader("Push", ImGuiTreeNodeFlags_DefaultOpen)) {
    const char* bodies[] = {"pelvis", "thorax", "head"};
    ImGui::Combo("body", &ui.push_body, bodies, 3);
    ImGui::SliderFloat("force (N)", &ui.push_force_N, 0.0f, 1000.0f, "%.0f");
    ImGui::SliderFloat("direction (deg)", &ui.push_direction_deg, -180.0f, 180.0f, "%.0f");
    ImGui::SliderFloat("duration (s)", &ui.push_duration_s, 0.05f, 1.0f, "%.2f");
    if (ImGui::Button("Push (P)")) {
      push_relative(s, bodies[ui.push_body], ui.push_force_N, ui.push_direction_deg,
                    ui.push_duration_s);
    }
    ImGui::TextDisabled("direction: 0 = forward along the heading, 90 = to the left");
    ImGui::TextDisabled("or ctrl + drag on a body: 2 N per pixel, for the duration above");
  }
}

// Save and load the walker's and the controller's parameters as the CLI reads them.
void parameter_files_section(Shared& sh, scenarios::LiveScenario& s, UiState& ui) {
  if (ImGui::CollapsingHeader("Parameter files")) {
    ImGui::InputText("walker", ui.walker_path, sizeof ui.walker_path);
    ImGui::InputText("controller", ui.controller_path, sizeof ui.controller_path);
    if (ImGui::Button("Save")) {
      save_params(s, ui.walker_path, ui.controller_path);
      sh.message = std::string("saved ") + ui.walker_path + " and " + ui.controller_path +
                   " (biodyn walk --params / --controller-params read them)";
    }
    ImGui::SameLine();
    if (ImGui::Button("Load")) {
      if (s.walking()) {
        controllers::TorqueWalkerParams p;
        controllers::apply_torque_walker_json(sim::read_file(ui.walker_path), ui.walker_path, &p);
        s.set_gait_params(p);
      }
      controllers::ControllerParams p = current_controller_params(s);
      controllers::apply_params_json(sim::read_file(ui.controller_path), ui.controller_path,
                                     s.rig().groups(), &p);
      s.set_controller_params(p);
      sh.message = "loaded the parameter files";
    }
  }
}

void control_panel(Shared& sh, UiState& ui) {
  scenarios::LiveScenario& s = *sh.scenario;
  ImGui::SetNextWindowPos(ImVec2(10, 310), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(400, 520), ImGuiCond_FirstUseEver);
  ImGui::Begin("Controllers");
  try {
    if (s.controller() == nullptr) {
      ImGui::TextDisabled(
          "a kinematic playback: no controllers (biodyn mocap id gives its forces)");
      ImGui::End();
      return;
    }
    // Foot contact.
    int weld = static_cast<int>(s.config().weld);
    const char* modes[] = {"off", "honest", "glue"};
    if (ImGui::Combo("foot contact", &weld, modes, 3))
      s.set_weld_mode(static_cast<controllers::WeldMode>(weld));
    if (s.walking()) {
      int drive = static_cast<int>(s.config().walker_actuation);
      const char* drives[] = {"torque (PD)", "velocity-based"};
      if (ImGui::Combo("joint drive", &drive, drives, 2))
        s.set_walker_actuation(static_cast<controllers::WalkerActuation>(drive));
      float v = static_cast<float>(s.config().speed_m_s);
      if (ImGui::SliderFloat("speed (m/s)", &v, static_cast<float>(scenarios::kMinWalkSpeed_m_s),
                             static_cast<float>(scenarios::kMaxWalkSpeed_m_s))) {
        s.set_speed(v);
      }
      float h = static_cast<float>(s.config().heading_rate_deg_s);
      const float max_rate = static_cast<float>(scenarios::kMaxHeadingRate_deg_s);
      if (ImGui::SliderFloat("heading rate (deg/s)", &h, -max_rate, max_rate))
        s.set_heading_rate(h);
      gait_section(s);
    }
    joint_groups_section(s);
    push_section(s, ui);
    parameter_files_section(sh, s, ui);
  } catch (const sim::Error& e) {
    sh.message = e.what();  // a bad value or file, a file that cannot be written: said
  }
  ImGui::End();
}

void balance_plots(Shared& sh) {
  const Plots& p = sh.plots;
  const ImVec2 size(0, 50);
  ImGui::PlotLines("CoM outside support (m)", p.com_outside.data(), Plots::kSamples, p.head,
                   nullptr, 0.0f, 0.3f, size);
  if (sh.scenario->walking()) {
    ImGui::PlotLines("CoM outside tolerance (m)", p.tolerance_outside.data(), Plots::kSamples,
                     p.head, nullptr, 0.0f, 0.3f, size);
  }
  ImGui::PlotLines("CoM speed (m/s)", p.speed.data(), Plots::kSamples, p.head, nullptr, 0.0f, 2.0f,
                   size);
  ImGui::PlotHistogram("left foot contact", p.contact_l.data(), Plots::kSamples, p.head, nullptr,
                       0.0f, 1.0f, ImVec2(0, 14));
  ImGui::PlotHistogram("right foot contact", p.contact_r.data(), Plots::kSamples, p.head, nullptr,
                       0.0f, 1.0f, ImVec2(0, 14));
  for (std::size_t g = 0; g < p.groups.size(); ++g) {
    const std::string label = "|tau| / tau_max " + p.groups[g];
    ImGui::PlotLines(label.c_str(), p.torque_ratio[g].data(), Plots::kSamples, p.head, "limit = 1",
                     0.0f, 1.05f, ImVec2(0, 36));
  }
}

// The live plots; with muscles on, the muscles' own (opened first) and the balance plots in tabs.
void plot_panel(Shared& sh, UiState& ui, int window_width) {
  ImGui::SetNextWindowPos(ImVec2(static_cast<float>(window_width) - 430, 10),
                          ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(420, 640), ImGuiCond_FirstUseEver);
  if (sh.muscle_plots.empty()) {
    ImGui::Begin("Plots (last 10 s)");
    balance_plots(sh);
    ImGui::End();
    return;
  }
  ImGui::Begin("Plots");
  if (ImGui::BeginTabBar("plots")) {
    if (ImGui::BeginTabItem("Muscles (last 5 s)")) {
      sh.muscle_plots.draw(&ui.muscle_leg);
      ImGui::EndTabItem();
    }
    if (ImGui::BeginTabItem("Balance, torques (last 10 s)")) {
      balance_plots(sh);
      ImGui::EndTabItem();
    }
    ImGui::EndTabBar();
  }
  ImGui::End();
}

// ---------------------------------------------------------------------------------------------
// The window's side: a GLFW window with Dear ImGui, and the frame loop around the physics thread
// ---------------------------------------------------------------------------------------------

/// The window and Dear ImGui on it, created and torn down in order.
class Window {
 public:
  explicit Window(const ViewerOptions& o) {
    if (!glfwInit()) {
      throw sim::Error(
          "view: cannot open a window (no display?): use biodyn render for headless "
          "output, or run under xvfb-run");
    }
    glfwWindowHint(GLFW_SAMPLES, o.msaa_samples);
    window_ = glfwCreateWindow(o.width, o.height, "biodyn view", nullptr, nullptr);
    if (window_ == nullptr) {
      glfwTerminate();
      throw sim::Error("view: cannot create a GLFW window with OpenGL");
    }
    glfwMakeContextCurrent(window_);
    glfwSwapInterval(1);
    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini written into the user's directory
    ImGui_ImplGlfw_InitForOpenGL(window_, true);
    ImGui_ImplOpenGL3_Init("#version 130");
  }
  ~Window() {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    glfwDestroyWindow(window_);
    keep_gl_libraries_loaded();
    glfwTerminate();
  }
  Window(const Window&) = delete;
  Window& operator=(const Window&) = delete;
  GLFWwindow* get() const { return window_; }

 private:
  GLFWwindow* window_ = nullptr;
};

/// One viewer session: the scene, panels and inputs of every frame (the main thread), the physics
/// on its own thread; the main thread holds the lock only to copy the scene and plot samples and
/// to run the panels.
class Session {
 public:
  Session(scenarios::LiveScenario& scenario, const std::vector<ScriptCommand>& script,
          const ViewerOptions& options)
      : options_(options),
        renderer_(scenario.simulation().mutable_model(), 1920, 1080),
        display_(scenario.simulation().model()),
        pelvis_(scenario.rig().pelvis()) {
    sh_.scenario = &scenario;
    sh_.script = &script;
    sh_.script_path = options.script_path;
    sh_.paused = options.start_paused;
    // 12 s of history (at 2 ms steps: an entry every 10 ms).
    const mjModel& m = scenario.simulation().model();
    const int muscles = scenario.muscles() ? scenario.muscles()->set().size() : 0;
    sh_.history.init(static_cast<int>(std::ceil(12.0 / (History::kEvery * m.opt.timestep))), m.nq,
                     muscles, m.opt.timestep);
    sh_.muscle_plots.init(scenario);
    const models::Rig& rig = scenario.rig();
    for (const char* g : {"hip_l", "knee_l", "ankle_l", "hip_r", "knee_r", "ankle_r"}) {
      const int i = rig.group(g);
      if (i < 0) continue;
      sh_.plots.groups.push_back(g);
      sh_.plots.group_index.push_back(i);
    }
    if (const int back = rig.lower_back(); back >= 0) {  // the lumbar, or the gait model's trunk
      sh_.plots.groups.push_back(rig.groups()[static_cast<std::size_t>(back)].name);
      sh_.plots.group_index.push_back(back);
    }
    sh_.plots.torque_ratio.resize(sh_.plots.groups.size());
    sim::CameraView& v = renderer_.view();
    v.azimuth_deg = 110;
    v.elevation_deg = -10;
    v.distance_m = 4.0;
    v.lookat_W.z() = 0.9;
  }

  /// Runs until the window closes or the script quits. Throws sim::InvalidArgument for a script
  /// command the scenario refused.
  ViewerStats run(GLFWwindow* window) {
    std::thread physics([this] { physics_loop(sh_); });
    struct Joiner {  // the physics thread stops however the loop ends
      Shared& sh;
      std::thread& t;
      ~Joiner() {
        {
          std::lock_guard<std::mutex> lock(sh.mutex);
          sh.quit = true;
        }
        if (t.joinable()) t.join();
      }
    } joiner{sh_, physics};
    start_ = fps_clock_ = last_record_ = Clock::now();
    while (!glfwWindowShouldClose(window) && frame(window)) {
    }
    if (video_) video_->finish();
    final_stats();
    physics.join();
    if (!sh_.script_error.empty()) throw sim::InvalidArgument(sh_.script_error);
    stats_.wall_s = std::chrono::duration<double>(Clock::now() - start_).count();
    stats_.frames_per_s = stats_.frames / std::max(stats_.wall_s, 1e-9);
    return stats_;
  }

 private:
  struct Drag {
    int body = -1;  // the body being pushed by a ctrl + drag, -1 when none
    double start_x = 0, start_y = 0;
    Eigen::Vector3d force_W = Eigen::Vector3d::Zero();
  };

  // One frame; false once the session quits.
  bool frame(GLFWwindow* window) {
    glfwPollEvents();
    bool take_screenshot = false;
    std::string screenshot_path;
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    int width = 0, height = 0;
    glfwGetFramebufferSize(window, &width, &height);
    {
      std::lock_guard<std::mutex> lock(sh_.mutex);
      if (sh_.quit) return false;
      if (sh_.screenshot_requested) {
        take_screenshot = true;
        screenshot_path = sh_.screenshot_path;
      }
      // Keys and the mouse not while typing into or dragging a panel.
      if (!ImGui::GetIO().WantCaptureKeyboard) keys(width, height, &take_screenshot);
      mouse(window);
      renderer_.follow(ui_.follow ? pelvis_ : -1);
      // Panels read and edit the scenario under the lock (edits are only logged here).
      simulation_panel(sh_, ui_, fps_, sim_rate_);
      control_panel(sh_, ui_);
      plot_panel(sh_, ui_, width);
      update_scene();
      rates();
      status_line(height);
    }
    // Render without the lock: the muscles' colours, copied under it, go onto the scene first.
    color_muscles(tendon_rgba_, &renderer_);
    renderer_.render_to_window(width, height);
    outputs(width, height, take_screenshot, screenshot_path);
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    glfwSwapBuffers(window);
    ++stats_.frames;
    return true;
  }

  // Keys (GLFW key codes: imgui 1.86's backend).
  void keys(int width, int height, bool* take_screenshot) {
    scenarios::LiveScenario& scenario = *sh_.scenario;
    if (ImGui::IsKeyPressed(GLFW_KEY_SPACE, false)) sh_.paused = !sh_.paused;
    if (ImGui::IsKeyPressed(GLFW_KEY_PERIOD, false)) sh_.single_steps += 1;
    if (ImGui::IsKeyPressed(GLFW_KEY_BACKSPACE, false)) {
      scenario.reset();
      sh_.history.count = 0;
      sh_.scrub_s = 0;
    }
    if (ImGui::IsKeyPressed(GLFW_KEY_P, false)) {
      push_relative(scenario, "pelvis", ui_.push_force_N, ui_.push_direction_deg,
                    ui_.push_duration_s);
    }
    if (ImGui::IsKeyPressed(GLFW_KEY_F2, false)) *take_screenshot = true;
    if (ImGui::IsKeyPressed(GLFW_KEY_F3, false)) {
      if (video_) {
        video_->finish();
        sh_.message = "video written";
        video_.reset();
      } else {
        const std::string path =
            options_.output_dir + "/biodyn_" + std::to_string(shot_counter_++) + ".mp4";
        video_.emplace(path, width & ~1, height & ~1, 30.0);
        sh_.message = "recording " + path + " (F3 stops)";
      }
    }
  }

  // Mouse: orbit (left), pan (right), zoom (wheel) outside the panels; ctrl + drag pushes a body.
  void mouse(GLFWwindow* window) {
    double mx = 0, my = 0;
    glfwGetCursorPos(window, &mx, &my);
    const bool left = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
    const bool ctrl = glfwGetKey(window, GLFW_KEY_LEFT_CONTROL) == GLFW_PRESS ||
                      glfwGetKey(window, GLFW_KEY_RIGHT_CONTROL) == GLFW_PRESS;
    int win_w = 1, win_h = 1;
    glfwGetWindowSize(window, &win_w, &win_h);
    sim::Simulation& simulation = sh_.scenario->simulation();
    if (drag_.body < 0 && left && ctrl && !ImGui::GetIO().WantCaptureMouse) {
      // Ctrl + drag on a body: pick it (MuJoCo's ray selection), the drag sets the push.
      mjtNum point[3] = {0, 0, 0};
      int geom = -1, skin = -1;
      const int body = mjv_select(&simulation.model(), &simulation.data(), &renderer_.options(),
                                  static_cast<mjtNum>(win_w) / win_h, mx / win_w, 1.0 - my / win_h,
                                  &renderer_.scene(), point, &geom, &skin);
      if (body > 0) drag_ = Drag{body, mx, my, Eigen::Vector3d::Zero()};
    }
    if (drag_.body >= 0) {
      drag_push(mx, my, left);
    } else if (!ImGui::GetIO().WantCaptureMouse) {
      const double dx = mx - last_mouse_x_, dy = my - last_mouse_y_;
      sim::CameraView& v = renderer_.view();
      if (left) {
        v.azimuth_deg -= 0.3 * dx;
        v.elevation_deg = std::clamp(v.elevation_deg - 0.3 * dy, -89.0, 89.0);
      }
      if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS) {
        ui_.follow = false;
        const double a = v.azimuth_deg * kRadPerDeg, k = 0.002 * v.distance_m;
        v.lookat_W += k * (dx * Eigen::Vector3d(std::sin(a), -std::cos(a), 0) +
                           dy * Eigen::Vector3d(0, 0, 1));
      }
      const float wheel = ImGui::GetIO().MouseWheel;
      if (wheel != 0) v.distance_m = std::clamp(v.distance_m * std::pow(0.9, wheel), 0.5, 30.0);
    }
    last_mouse_x_ = mx;
    last_mouse_y_ = my;
  }

  // A ctrl + drag in progress: screen right and up map to the ground plane as the camera sees
  // it; released, the push is made.
  void drag_push(double mx, double my, bool left) {
    const double a = renderer_.view().azimuth_deg * kRadPerDeg;
    const Eigen::Vector3d right(std::sin(a), -std::cos(a), 0), ahead(std::cos(a), std::sin(a), 0);
    drag_.force_W =
        kDragNewtonsPerPixel * ((mx - drag_.start_x) * right - (my - drag_.start_y) * ahead);
    if (left) return;
    if (drag_.force_W.norm() >= 1.0) {
      const char* name = mj_id2name(&sh_.scenario->simulation().model(), mjOBJ_BODY, drag_.body);
      sh_.scenario->push(name, drag_.force_W, ui_.push_duration_s);
      sh_.message = std::string("pushed ") + name + " with " +
                    std::to_string(static_cast<int>(drag_.force_W.norm())) + " N for " +
                    std::to_string(ui_.push_duration_s) + " s";
    }
    drag_.body = -1;
  }

  // The scene: a past state while scrubbing back, else the live one with its overlays and the
  // drag's arrow.
  void update_scene() {
    sim::Simulation& simulation = sh_.scenario->simulation();
    if (sh_.scrub_s < 0 && sh_.history.count > 0) {
      const int back = std::clamp(static_cast<int>(std::lround(-sh_.scrub_s / sh_.history.entry_s)),
                                  0, sh_.history.count - 1);
      const std::vector<double>& q =
          sh_.history.qpos[static_cast<std::size_t>(sh_.history.at(back))];
      std::copy(q.begin(), q.end(), display_->qpos);
      mj_forward(&simulation.model(), display_.get());
      overlays_.clear();
      muscle_scene_options(*sh_.scenario, ui_.overlays, &renderer_.options());
      renderer_.update_scene(simulation.model(), *display_, overlays_);
      // The muscles as they were then.
      tendon_colors(*sh_.scenario,
                    sh_.history.activation[static_cast<std::size_t>(sh_.history.at(back))],
                    &tendon_rgba_);
      return;
    }
    build_overlays(*sh_.scenario, ui_.overlays, &sh_.overlay_buffers, &overlays_);
    if (drag_.body >= 0 && drag_.force_W.norm() > 0) {
      sim::OverlayGeom g;
      g.kind = sim::OverlayGeom::Kind::kArrow;
      g.to_W = Eigen::Vector3d(simulation.data().xipos + 3 * drag_.body);
      g.from_W = g.to_W - ui_.overlays.force_scale_m_per_N * drag_.force_W;
      g.width_m = 0.02;
      const float yellow[4] = {1.0f, 0.85f, 0.1f, 1.0f};
      std::copy(yellow, yellow + 4, g.rgba);
      overlays_.push_back(g);
    }
    muscle_scene_options(*sh_.scenario, ui_.overlays, &renderer_.options());
    renderer_.update_scene(simulation.model(), simulation.data(), overlays_);
    muscle_activations(*sh_.scenario, &activation_);
    tendon_colors(*sh_.scenario, activation_, &tendon_rgba_);
  }

  // Frame and physics rates, once a second.
  void rates() {
    const double since = std::chrono::duration<double>(Clock::now() - fps_clock_).count();
    ++fps_frames_;
    if (since < 1.0) return;
    fps_ = fps_frames_ / since;
    sim_rate_ = (sh_.running_sim_s - sim_at_fps_) / since;
    sim_at_fps_ = sh_.running_sim_s;
    fps_frames_ = 0;
    fps_clock_ = Clock::now();
  }

  void status_line(int height) {
    const scenarios::LiveScenario& s = *sh_.scenario;
    ImGui::SetNextWindowPos(ImVec2(10, static_cast<float>(height) - 30), ImGuiCond_Always);
    ImGui::Begin("status", nullptr,
                 ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize |
                     ImGuiWindowFlags_NoBackground);
    ImGui::Text(
        "%s  [space] pause  [.] step  [P] push  [ctrl+drag] push a body  [F2] screenshot  [F3] "
        "record  %s",
        s.playback() ? "playback" : controllers::to_string(s.config().weld), sh_.message.c_str());
    ImGui::End();
  }

  // Screenshots and video frames, read back from the window (without the lock).
  void outputs(int width, int height, bool take_screenshot, const std::string& screenshot_path) {
    if (take_screenshot) {
      renderer_.read_window(width, height, &rgb_);
      const std::string path =
          screenshot_path.empty()
              ? options_.output_dir + "/biodyn_" + std::to_string(shot_counter_++) + ".png"
              : screenshot_path;
      write_png(path, width, height, rgb_);
      ++stats_.screenshots;
      std::lock_guard<std::mutex> lock(sh_.mutex);
      sh_.message = "screenshot " + path;
      sh_.screenshot_requested = false;  // the physics goes on
    }
    if (video_ &&
        std::chrono::duration<double>(Clock::now() - last_record_).count() >= 1.0 / 30.0) {
      last_record_ = Clock::now();
      renderer_.read_window(width & ~1, height & ~1, &rgb_);
      video_->add_frame(rgb_);
    }
  }

  // What the session summary reports, at its end (stops the physics).
  void final_stats() {
    std::lock_guard<std::mutex> lock(sh_.mutex);
    sh_.quit = true;
    const scenarios::LiveScenario& s = *sh_.scenario;
    stats_.simulated_s = s.time_s();
    const sim::CenterOfMass com =
        sim::center_of_mass(s.simulation().model(), s.simulation().data());
    stats_.com_x_m = com.position_W.x();
    stats_.com_y_m = com.position_W.y();
    stats_.fallen = s.fallen();
    stats_.pushes = static_cast<int>(s.pushes().size());
    stats_.stones_plan_m = s.config().steps_m;
    stats_.stones = s.stones();
    stats_.tracking = s.tracking_report();
    stats_.muscles = s.muscle_report();
    stats_.physics_steps_per_s =
        sh_.running_wall_s > 0 ? static_cast<double>(sh_.steps_run) / sh_.running_wall_s : 0;
    stats_.realtime_factor = sh_.running_wall_s > 0 ? sh_.running_sim_s / sh_.running_wall_s : 0;
  }

  const ViewerOptions& options_;
  Shared sh_;
  sim::SceneRenderer renderer_;
  sim::Data display_;  // a past state shown while scrubbing
  const int pelvis_;
  UiState ui_;
  Drag drag_;
  ViewerStats stats_;
  std::vector<sim::OverlayGeom> overlays_;
  std::vector<float> activation_, tendon_rgba_;  // copied under the lock, drawn without it
  std::vector<std::uint8_t> rgb_;
  std::optional<VideoWriter> video_;
  int shot_counter_ = 0;
  double last_mouse_x_ = 0, last_mouse_y_ = 0;
  Clock::time_point start_, fps_clock_, last_record_;
  int fps_frames_ = 0;
  double fps_ = 0, sim_rate_ = 0, sim_at_fps_ = 0;
};

}  // namespace

ViewerStats run_viewer(scenarios::ScenarioConfig config, const ViewerOptions& options) {
  const std::vector<ScriptCommand> script = options.script_path.empty()
                                                ? std::vector<ScriptCommand>{}
                                                : parse_script(options.script_path);
  scenarios::LiveScenario scenario(std::move(config));
  const Window window(options);
  Session session(scenario, script, options);
  return session.run(window.get());
}

}  // namespace biodyn::viewer
