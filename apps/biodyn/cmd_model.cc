// biodyn model: generate a character's MJCF from the anthropometric tables.
#include <iostream>
#include <memory>

#include "biodyn/models/mjcf.h"
#include "biodyn/sim/model.h"
#include "cli_common.h"
#include "commands.h"

namespace biodyn::apps {

Command add_model_command(CLI::App* app) {
  struct Options {
    CharacterOptions character;
    std::string output = "character.xml";
    std::string summary;
    bool muscles = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app->add_subcommand(
      "model", "Generate a character (MJCF) from height, mass and sex (de Leva 1996 tables)");
  o->character.add_to(cmd);
  cmd->add_option("-o,--output", o->output, "MJCF file to write")->capture_default_str();
  cmd->add_flag("--muscles", o->muscles,
                "add the legs' Hill muscles (Rajagopal 2016, scaled to the body): sites, "
                "wrapping cylinders and one spatial tendon per muscle");
  cmd->add_option("--summary", o->summary,
                  "JSON file listing every segment's mass, length, CoM and inertia");
  return {cmd, [o]() {
            models::CharacterSpec spec = o->character.to_spec();
            spec.muscles = o->muscles;
            const models::Character character = models::generate_character(spec);
            const std::string xml = models::to_mjcf(character);
            // Compile before writing: a model MuJoCo rejects is never written.
            const sim::Model model = sim::Model::from_string(xml, o->output);
            std::string summary;
            if (!o->summary.empty()) summary = models::summary_json(character);
            write_file_atomically(o->output, xml);
            if (!o->summary.empty()) write_file_atomically(o->summary, summary);
            std::cout << "wrote " << o->output << ": " << to_string(spec.sex) << ", "
                      << spec.height_m << " m, " << character.total_mass_kg() << " kg, "
                      << to_string(spec.detail) << " detail, " << character.segments.size()
                      << " segments, " << model->nv << " DOF (" << model->nu
                      << " actuated), standing height " << character.standing_height_m << " m";
            if (!character.muscles.empty())
              std::cout << ", " << character.muscles.size() << " muscles";
            std::cout << "\n";
            if (!o->summary.empty()) std::cout << "wrote " << o->summary << "\n";
            return kExitOk;
          }};
}

}  // namespace biodyn::apps
