#pragma once
// The default character with its marker sites, as the capture tests film it.
#include <vector>

#include "biodyn/models/character.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/model.h"

namespace biodyn::testing {

struct FilmedCharacter {
  models::Character character = models::generate_character({});
  sim::Model model = sim::Model::from_string(models::to_mjcf(character), "character");
  std::vector<int> sites;  ///< each marker's site, in the character's marker order

  FilmedCharacter() {
    const models::Rig rig(*model.get());
    for (const models::Marker& mk : character.markers) sites.push_back(rig.marker_site(mk.name));
  }
};

}  // namespace biodyn::testing
