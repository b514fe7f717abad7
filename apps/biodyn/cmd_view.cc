// biodyn view: the interactive viewer (issue 6; viewer_app.h).
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <tuple>

#include "biodyn/sim/errors.h"
#include "biodyn/viewer/viewer_app.h"
#include "cli_common.h"
#include "commands.h"
#include "view_options.h"
#include "walk_options.h"

namespace biodyn::apps {

Command add_view_command(CLI::App* app) {
  struct Options {
    ViewOptions view;
    viewer::ViewerOptions viewer;
    std::string size = "1600x900";
    std::string summary_path;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app->add_subcommand(
      "view",
      "Interactive viewer: the character in a scenario, live parameter panels, pushes, "
      "plots, rewind (needs a display; biodyn render works without one)");
  o->view.add_to(cmd);
  cmd->add_option("--script", o->viewer.script_path,
                  "Commands at simulated times (set, push, save-params, screenshot, rewind, quit; "
                  "see apps/viewer/include/biodyn/viewer/viewer_app.h)");
  cmd->add_option("--output-dir", o->viewer.output_dir, "Where F2 screenshots and F3 videos go")
      ->capture_default_str();
  cmd->add_flag("--paused", o->viewer.start_paused, "Start paused");
  cmd->add_option("--msaa", o->viewer.msaa_samples,
                  "Window multisampling (0: off, faster without a GPU)")
      ->capture_default_str();
  cmd->add_option("--summary", o->summary_path, "Session summary JSON to write at exit");
  cmd->add_option("--size", o->size, "Window size WIDTHxHEIGHT")->capture_default_str();
  return {cmd, [o]() {
            std::tie(o->viewer.width, o->viewer.height) = parse_size(o->size, "--size");
            if (o->viewer.width < 320 || o->viewer.height < 240) {
              throw sim::InvalidArgument(
                  "--size: expected WIDTHxHEIGHT of at least 320x240, got '" + o->size + "'");
            }
            std::cout << "view " << o->view.scenario << ": " << o->view.assumption() << "\n";
            std::vector<std::string> body_notes;
            const scenarios::ScenarioConfig config = o->view.to_config(&body_notes);
            for (const std::string& n : body_notes) std::cout << "view: note: " << n << "\n";
            const viewer::ViewerStats st = viewer::run_viewer(config, o->viewer);
            std::cout << "view: " << st.frames << " frames in " << st.wall_s << " s ("
                      << st.frames_per_s << " frames/s); simulated " << st.simulated_s
                      << " s, physics " << st.physics_steps_per_s << " steps/s ("
                      << st.realtime_factor << "x real time while running); " << st.screenshots
                      << " screenshots\n";
            const std::string stones = stones_line(st.stones_plan_m, st.stones);
            if (!stones.empty()) std::cout << "  " << stones << "\n";
            const std::string tracking = tracking_line(st.tracking);
            if (!tracking.empty()) std::cout << "  " << tracking << "\n";
            print_muscles(st.muscles, std::cout);
            if (!o->summary_path.empty()) {
              nlohmann::json j = {{"scenario", o->view.scenario},
                                  {"frames", st.frames},
                                  {"wall_s", st.wall_s},
                                  {"frames_per_s", st.frames_per_s},
                                  {"simulated_s", st.simulated_s},
                                  {"physics_steps_per_s", st.physics_steps_per_s},
                                  {"realtime_factor", st.realtime_factor},
                                  {"screenshots", st.screenshots},
                                  {"com_x_m", st.com_x_m},
                                  {"com_y_m", st.com_y_m},
                                  {"fallen", st.fallen},
                                  {"pushes", st.pushes},
                                  {"assumption", o->view.assumption()}};
              if (o->view.scenario == "stones")
                j["stones"] = stones_json(st.stones_plan_m, st.stones, config.steps_lateral_m);
              if (st.tracking.tracked) j["tracking"] = tracking_json(st.tracking);
              if (st.muscles) j["muscles"] = muscles_json(st.muscles);
              write_file_atomically(o->summary_path, j.dump(1) + "\n");
            }
            return kExitOk;
          }};
}

}  // namespace biodyn::apps
