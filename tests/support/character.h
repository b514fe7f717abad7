#pragma once
// A generated character's compiled model, for the tests of the layers above models/.
#include "biodyn/models/mjcf.h"
#include "test_support.h"

namespace biodyn::testing {

/// The character `spec` describes, generated and compiled (in the scene `options` give, e.g.
/// a terrain).
inline sim::Model generated_character(const models::CharacterSpec& spec,
                                      const models::PhysicsOptions& options = {}) {
  return load_inline(models::to_mjcf(models::generate_character(spec), options));
}

/// The character `spec` describes with the legs' Hill muscles (its muscle list and anatomy;
/// to_mjcf makes its model).
inline models::Character muscled_character(models::CharacterSpec spec) {
  spec.muscles = true;
  return models::generate_character(spec);
}

/// The default character (1.80 m, 80 kg, male) in gait detail with the legs' Hill muscles.
inline models::Character muscled_character() {
  models::CharacterSpec spec;
  spec.detail = models::Detail::kGait;
  return muscled_character(spec);
}

/// The default character (1.80 m, 80 kg, male) in `detail`, compiled.
inline sim::Model generated_character(models::Detail detail = models::Detail::kFull) {
  models::CharacterSpec spec;
  spec.detail = detail;
  return generated_character(spec);
}

}  // namespace biodyn::testing
