#pragma once
/// Marker sets as data (JSON): which marker rides on which part and where (MarkerPlacement),
/// its weight in marker IK, and the marker pairs whose distances scale segments from a static
/// trial (OpenSim's "measurements"). Built in: "thesis26" (the thesis's 26 markers,
/// markers_26.csv), "full40" (those 26 plus 14 that make every joint of the full character
/// observable, markersets/full40_extra.json) and "opensim_walking5" (the 40-marker Vicon set of
/// OpenSim's walking5.c3d test capture, markersets/opensim_walking5.json).
///
/// JSON:
///   {"name": "my_set", "description": "...",
///    "markers": [{"name": "LASI", "part": "pelvis", "along": 0.55, "ant": 1, "lat": 0.6,
///                 "sup": 0, "weight": 1, "fixed": false, "description": "..."},
///                {"name": "X", "part": "thigh_l", "offset_m": [0.0, 0.08, -0.2]}],
///    "scaling": [{"segments": ["thigh_l"], "pairs": [["LHJC", "LKJC"]]},
///                {"segments": ["pelvis"], "dimension": "width", "pairs": [["LHJC", "RHJC"]]}]}

#include <map>
#include <set>
#include <string>
#include <vector>

#include "biodyn/models/character.h"

namespace biodyn::models {

/// Segment lengths from marker distances: every segment listed gets the factor
/// mean(measured distance) / mean(model distance) over the pairs (OpenSim's ScaleTool
/// measurement).
struct ScaleMeasurement {
  /// What the factor scales: "length" (SegmentOverride::length_m, the default) or "width"
  /// (SegmentOverride::width_m: the pelvis's hip joint separation).
  std::string dimension = "length";
  std::vector<std::string> segments;  ///< override keys, e.g. "thigh_l", "lumbar"
  std::vector<std::pair<std::string, std::string>> pairs;  ///< marker names
};

struct MarkerSet {
  std::string name;
  std::string description;
  std::vector<MarkerPlacement> markers;
  std::map<std::string, double> weights;  ///< IK weight per marker (1 unless given), >= 0
  /// Markers a static trial does not move (bony landmarks trusted as placed); the others get
  /// their offsets from the static trial (OpenSim's MarkerPlacer).
  std::set<std::string> fixed;
  std::vector<ScaleMeasurement> scaling;

  /// IK weight of `marker` (1 when the set gives none).
  double weight(const std::string& marker) const;
};

/// Parses a marker set; `source` names the file in errors. Throws sim::InvalidArgument naming
/// the file, the field (markers[3].part, ...), the rule and the value: malformed JSON, unknown
/// field, missing name/part, both fractions and offset_m, a negative weight, a duplicate name,
/// a scaling pair naming a marker the set does not have.
MarkerSet parse_marker_set(const std::string& json_text, const std::string& source);

/// Names of the built-in marker sets.
std::vector<std::string> builtin_marker_set_names();
/// A built-in marker set by name; throws sim::InvalidArgument listing the names otherwise.
MarkerSet builtin_marker_set(const std::string& name);

}  // namespace biodyn::models
