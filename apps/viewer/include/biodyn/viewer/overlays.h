#pragma once
/// What the viewer and `biodyn render` draw over the character (issue 6): the support polygon
/// (the feet's floor contacts), the tolerance polygon of the base-polygon balance (paper §4.3,
/// walking), the CoM's ground projection, contact forces, active pushes as arrows, the foot
/// welds (green when on, red when the weld pulled: a tension flag) and the stepping stones
/// (scenario stones: grey until stepped on, then green within 2 cm of the planned length,
/// orange beyond).
#include <array>
#include <vector>

#include "biodyn/scenarios/live.h"
#include "biodyn/sim/renderer.h"

namespace biodyn::viewer {

struct OverlayOptions {
  bool support_polygon = true;
  bool tolerance_polygon = true;
  bool com_projection = true;
  bool contact_forces = true;
  bool pushes = true;
  bool welds = true;
  bool stones = true;
  double force_scale_m_per_N = 0.001;  ///< arrow length per newton (1 m per kN)
};

/// Scratch reused frame to frame (no allocation once grown).
struct OverlayBuffers {
  std::vector<sim::FloorContact> contacts;
  std::vector<Eigen::Vector2d> points, hull, tolerance;
};

/// The current floor contacts (`contacts`) and the feet's support polygon (`hull`): what the
/// overlays draw and the viewer's plots sample.
void foot_support(const mjModel& m, const mjData& d, const models::Rig& rig,
                  OverlayBuffers* buffers);

/// Appends the overlays of `s`'s current state to `out` (cleared first). Reads the simulation:
/// call under the physics lock, with the scene update.
void build_overlays(const scenarios::LiveScenario& s, const OverlayOptions& options,
                    OverlayBuffers* buffers, std::vector<sim::OverlayGeom>* out);

}  // namespace biodyn::viewer
