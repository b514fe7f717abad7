#pragma once
/// Scaling the generated character to a subject. From height alone it is the thesis's method
/// (the anthropometric tables scaled by stature: models::generate_character). From a static
/// trial it is OpenSim's ScaleTool: segment lengths from marker distances (the marker set's
/// "scaling" pairs), then the MarkerPlacer: the markers not marked fixed are moved to where the
/// static trial puts them on the scaled body, after an IK fit of the static frames.

#include <map>
#include <string>
#include <vector>

#include "biodyn/mocap_io/marker_data.h"
#include "biodyn/models/character.h"
#include "biodyn/models/marker_set.h"

namespace biodyn::mocap_io {

struct ScaleOptions {
  /// Estimate the stature from the measured segments when the caller gave none: the base
  /// height is multiplied by the mean scale factor (then the factors are measured again).
  bool estimate_height = true;
  int placement_frames = 200;    ///< static frames (evenly spread) used to place markers
  int placement_iterations = 4;  ///< IK fit -> move markers rounds
};

/// One scaling measurement's outcome.
struct ScaleFactor {
  std::vector<std::string> segments;
  double measured_m = 0.0;  ///< mean marker distance in the static trial
  double model_m = 0.0;     ///< the same distance on the unscaled character
  double factor = 1.0;      ///< measured / model
  int frames = 0;           ///< frames in which every pair was visible
  int measurement = 0;      ///< index into MarkerSet::scaling
};

struct ScaleResult {
  models::CharacterSpec spec;        ///< the scaled character: height, overrides, placed markers
  std::vector<ScaleFactor> factors;  ///< the measurements the trial allowed
  /// Measurements the trial could not make (a marker missing or never seen with its partner):
  /// their segments keep the height-scaled size. One sentence each.
  std::vector<std::string> unmeasured;
  std::vector<std::string> placed;  ///< markers moved by the static trial
  /// Marker error of the final static fit (over the placement frames), m.
  double static_rms_m = 0.0, static_max_m = 0.0;
};

/// Scales `base` (height, mass, sex, detail; its markers are replaced by `set`'s) to the
/// subject of `static_trial` (lab frame, z up, metres). `height_given` false lets the stature be
/// estimated (ScaleOptions::estimate_height). A measurement whose markers the trial lacks or
/// never shows together is skipped (ScaleResult::unmeasured). Throws sim::InvalidArgument when
/// too few frames have enough markers.
ScaleResult scale_from_static(const models::CharacterSpec& base, bool height_given,
                              const models::MarkerSet& set, const MarkerData& static_trial,
                              const ScaleOptions& options = {});

/// World positions of a character's markers in its standing pose (bodies parallel to the world),
/// by name.
std::map<std::string, Eigen::Vector3d> standing_marker_positions(const models::Character& c);

}  // namespace biodyn::mocap_io
