// biodyn: the command line. main() only dispatches; each subcommand lives in its own file.
#include <iostream>
#include <vector>

#include "biodyn/sim/errors.h"
#include "cli_common.h"
#include "commands.h"

int main(int argc, char** argv) {
  using namespace biodyn::apps;
  CLI::App app{"biodyn: physics-based character animation and biodynamics on MuJoCo 2.2.2"};
  app.name("biodyn");
  app.require_subcommand(1);
  bool verbose = false;
  app.add_flag("-v,--verbose", verbose, "Log info messages to stderr");
  const std::vector<Command> commands = {
      add_model_command(&app),       add_drop_command(&app),         add_pose_command(&app),
      add_stand_push_command(&app),  add_walk_command(&app),         add_push_command(&app),
      add_push_sweep_command(&app),  add_bench_command(&app),        add_mocap_command(&app),
      add_muscles_command(&app),     add_evaluate_command(&app),     add_render_command(&app),
      add_view_command(&app),        add_capture_command(&app),      add_gait_command(&app),
      add_walk_search_command(&app), add_stones_sweep_command(&app), add_walk_sweep_command(&app)};
  // Parse errors on one line, naming the option and the value.
  app.failure_message([](const CLI::App* cmd, const CLI::Error& e) {
    return "biodyn" + (cmd->get_parent() ? " " + cmd->get_name() : std::string()) +
           ": error: " + e.what() + " (see --help)\n";
  });
  if (argc == 1) {  // no subcommand: show what there is
    std::cout << app.help();
    return kExitBadInput;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitBadInput;
  }
  install_console_log(verbose);
  for (const Command& cmd : commands) {
    if (!cmd.cli->parsed()) continue;
    try {
      return cmd.run();
    } catch (const biodyn::sim::InvalidArgument& e) {
      std::cerr << "biodyn " << cmd.cli->get_name() << ": error: " << e.what() << "\n";
      return kExitBadInput;
    } catch (const biodyn::sim::Error& e) {
      std::cerr << "biodyn " << cmd.cli->get_name() << ": error: " << e.what() << "\n";
      return kExitFailure;
    } catch (const std::exception& e) {  // a bug: report it instead of aborting
      std::cerr << "biodyn " << cmd.cli->get_name() << ": internal error: " << e.what() << "\n";
      return kExitFailure;
    }
  }
  return kExitBadInput;
}
