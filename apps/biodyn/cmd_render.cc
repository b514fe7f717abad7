// biodyn render: a scenario filmed headless (issue 6): MP4 through ffmpeg, a PNG frame, and the
// run summary.
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <tuple>

#include "biodyn/sim/errors.h"
#include "biodyn/viewer/render_job.h"
#include "cli_common.h"
#include "commands.h"
#include "view_options.h"

namespace biodyn::apps {

Command add_render_command(CLI::App* app) {
  struct Options {
    ViewOptions view;
    viewer::RenderOptions render;
    std::string size = "1280x720";
    std::string summary_path;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app->add_subcommand(
      "render", "Film a scenario headless (no display needed): MP4 video and/or a PNG frame");
  o->view.add_to(cmd);
  cmd->add_option("--duration", o->render.duration_s, "Simulated seconds to film")
      ->capture_default_str();
  cmd->add_option("--fps", o->render.fps, "Video frames per simulated second")
      ->capture_default_str();
  cmd->add_option("--size", o->size, "Frame size WIDTHxHEIGHT (even)")->capture_default_str();
  cmd->add_option("-o,--output", o->render.video_path, "MP4 video to write");
  cmd->add_option("--png", o->render.png_path, "PNG frame to write");
  cmd->add_option("--png-time", o->render.png_time_s,
                  "Simulated time of the PNG frame, s (default: the last frame)");
  cmd->add_option("--azimuth", o->render.azimuth_deg, "Camera azimuth, deg")->capture_default_str();
  cmd->add_option("--elevation", o->render.elevation_deg, "Camera elevation, deg")
      ->capture_default_str();
  cmd->add_option("--distance", o->render.distance_m, "Camera distance, m")->capture_default_str();
  cmd->add_option("--summary", o->summary_path, "Run summary JSON to write");
  return {cmd, [o]() {
            std::tie(o->render.width, o->render.height) = parse_size(o->size, "--size");
            o->render.validate();
            std::vector<std::string> body_notes;
            scenarios::LiveScenario scenario(o->view.to_config(&body_notes));
            for (const std::string& n : body_notes) std::cout << "render: note: " << n << "\n";
            std::ostringstream label;
            label << "render " << o->view.scenario << ": " << o->render.duration_s << " s";
            ProgressBar bar(label.str());
            const viewer::RenderStats st =
                viewer::render_scenario(&scenario, o->render, [&](double f) { bar.update(f); });
            bar.finish();
            nlohmann::json summary = {
                {"scenario", o->view.scenario},
                {"character",
                 {{"height_m", scenario.config().character.height_m},
                  {"mass_kg", scenario.config().character.mass_kg}}},
                {"weld", o->view.weld},
                {"assumption", o->view.assumption()},
                {"simulated_s", st.simulated_s},
                {"fallen", st.fallen},
                {"frames", st.frames},
                {"size", o->size},
                {"wall_s", st.wall_s},
                {"physics_s", st.physics_s},
                {"render_s", st.render_s},
                {"encode_s", st.encode_s},
                {"render_frames_per_s", st.frames / std::max(st.render_s, 1e-9)},
                {"physics_realtime_factor", st.simulated_s / std::max(st.physics_s, 1e-9)},
                {"video", o->render.video_path},
                {"png", o->render.png_path}};
            // Only when the motion's header decided the body (a .csv motion): said so.
            if (!body_notes.empty()) summary["body_notes"] = body_notes;
            if (o->view.scenario == "stones")
              summary["stones"] = stones_json(scenario.config().steps_m, scenario.stones(),
                                              scenario.config().steps_lateral_m);
            if (scenario.tracker() != nullptr)
              summary["tracking"] = tracking_json(scenario.tracking_report());
            if (scenario.muscles() != nullptr)
              summary["muscles"] = muscles_json(scenario.muscle_report());
            if (o->view.terrain.kind != "flat") summary["terrain"] = o->view.terrain.json();
            if (!o->summary_path.empty()) {
              write_file_atomically(o->summary_path, summary.dump(1) + "\n");
            }
            std::cout << "render " << o->view.scenario << ": " << st.simulated_s << " s simulated"
                      << (st.fallen ? " (fell)" : " without falling") << ", " << st.frames
                      << " frames " << o->size << "; physics "
                      << summary["physics_realtime_factor"].get<double>()
                      << "x real time, rendering " << summary["render_frames_per_s"].get<double>()
                      << " frames/s" << o->view.terrain.text() << "\n  " << o->view.assumption()
                      << "\n";
            const std::string stones = stones_line(scenario.config().steps_m, scenario.stones());
            if (!stones.empty()) std::cout << "  " << stones << "\n";
            const std::string tracking = tracking_line(scenario.tracking_report());
            if (!tracking.empty()) std::cout << "  " << tracking << "\n";
            print_muscles(scenario.muscle_report(), std::cout);
            if (!o->render.video_path.empty())
              std::cout << "  video: " << o->render.video_path << "\n";
            if (!o->render.png_path.empty()) std::cout << "  frame: " << o->render.png_path << "\n";
            if (!o->summary_path.empty()) std::cout << "  summary: " << o->summary_path << "\n";
            return kExitOk;
          }};
}

}  // namespace biodyn::apps
