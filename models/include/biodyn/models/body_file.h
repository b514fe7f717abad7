#pragma once
/// A whole body as JSON ("body file"): what generate_character needs to rebuild exactly the
/// character an output was computed on, e.g. the body `biodyn mocap ik` scaled to a capture
/// (its segment lengths, pelvis width and placed markers) for `mocap id` and the viewer.
///
///   {"height_m": 1.87, "mass_kg": 80, "sex": "male", "detail": "full",
///    "segments": {"thigh_l": {"length_m": 0.446}},          (as --overrides files)
///    "markers": [{"name": "LASI", "part": "pelvis", "offset_m": [0.1, 0.07, 0.02]}]}
///
/// "segments" and "markers" are optional (no overrides; the thesis's 26 markers).

#include <string>

#include "biodyn/models/character.h"

namespace biodyn::models {

/// The body file of `spec`: one line when `compact` (a motion file's header), else indented.
/// Numbers keep 17 significant digits, so parse_body_json gives back the same spec.
std::string format_body_json(const CharacterSpec& spec, bool compact = false);

/// Parses a body file; `source` names it in errors. Throws sim::InvalidArgument naming the
/// field, the rule and the value (malformed JSON, unknown or missing field, bad sex/detail,
/// overrides or markers as their own parsers check them).
CharacterSpec parse_body_json(const std::string& json_text, const std::string& source);

/// The fields that fix a body's geometry (height, sex, detail, segment lengths and widths)
/// differ between `a` and `b`: a description of the differences (every whole-body one, else the
/// first segment's), or "" when they agree
/// (to 1e-6 relative). Mass and markers are not geometry: a motion's joint angles hold on
/// any mass.
std::string geometry_difference(const CharacterSpec& a, const CharacterSpec& b);

}  // namespace biodyn::models
