#pragma once
/// What the viewer and `biodyn render` draw over the character (issue 6): the support polygon
/// (the feet's floor contacts), the tolerance polygon of the base-polygon balance (paper §4.3,
/// walking), the CoM's ground projection, contact forces, active pushes as arrows, the foot
/// welds (green when on, red when the weld pulled: a tension flag) and the stepping stones
/// (scenario stones: grey until stepped on, then green within 2 cm of the planned length,
/// orange beyond). With muscles on, the muscles' paths (MuJoCo's spatial tendons) coloured by
/// activation.
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
  bool muscles = true;                 ///< the muscles' paths coloured by activation (--muscles on)
  bool wrap_cylinders = false;         ///< the cylinders the muscles' paths wrap around
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

/// A muscle's colour at activation `a` (clamped to [0, 1]): a dull grey-blue when relaxed,
/// bright red at full activation (linear in RGB between them, through a dusky rose). The
/// tendons in the scene and the activation plots.
std::array<float, 4> activation_rgba(double a);

/// The activations of `s`'s muscles now (muscles::MuscleSet's order), or empty without muscles.
/// Reads the scenario: call under the physics lock. No allocation once `out` has grown.
void muscle_activations(const scenarios::LiveScenario& s, std::vector<float>* out);

/// Per tendon of `s`'s model, RGBA (4 floats): a muscle's tendon coloured by its activation in
/// `activation` (muscle_activations' order; activation_rgba), any other tendon alpha -1 (keeps
/// the model's colour): for sim::SceneRenderer::recolor(mjOBJ_TENDON, ...). Without muscles, or
/// with `activation` empty, `out` is emptied (nothing recoloured). Reads only what is fixed for
/// the run (the muscles' tendons). No allocation once `out` has grown.
void tendon_colors(const scenarios::LiveScenario& s, const std::vector<float>& activation,
                   std::vector<float>* out);

/// Puts `tendon_rgba` (tendon_colors) on the tendons of `renderer`'s scene, drawn
/// kMusclePathWidthScale times as wide as the model says: after update_scene, before rendering.
void color_muscles(const std::vector<float>& tendon_rgba, sim::SceneRenderer* renderer);
/// The muscles' paths are drawn this many times as thick as the model's tendons (6 mm radius), to
/// be seen through the body.
inline constexpr float kMusclePathWidthScale = 2.0f;

/// Sets what the scene draws of `s`'s muscles in `options` as `o` says: with muscles, their
/// paths (MuJoCo's spatial tendons) and the body see-through (mjVIS_TRANSPARENT: the paths run
/// inside it), or neither; the cylinders the paths wrap around (geom group 3) hidden by
/// default.
void muscle_scene_options(const scenarios::LiveScenario& s, const OverlayOptions& o,
                          mjvOption* options);

}  // namespace biodyn::viewer
