// What the viewer and `biodyn render` draw over the character (viewer/overlays.h): the weld
// markers (green when on, red for a weld in tension), the stones, the support polygon, the
// muscles coloured by activation.
#include "biodyn/viewer/overlays.h"

#include <algorithm>
#include <numeric>
#include "biodyn/scenarios/live.h"
#include "test_support.h"

using namespace biodyn;

namespace {

bool is_red(const sim::OverlayGeom& g) {
  return g.rgba[0] > 0.9f && g.rgba[1] < 0.1f && g.rgba[2] < 0.1f;
}
bool is_green(const sim::OverlayGeom& g) {
  return g.rgba[1] > 0.8f && g.rgba[0] < 0.2f && g.rgba[2] < 0.2f;
}

// The weld markers: spheres 6 cm above a foot's origin.
int weld_markers(const scenarios::LiveScenario& s, const std::vector<sim::OverlayGeom>& out,
                 bool (*colour)(const sim::OverlayGeom&)) {
  const mjModel& m = s.simulation().model();
  const mjData& d = s.simulation().data();
  int n = 0;
  for (const char* foot : {"foot_l", "foot_r"}) {
    const int b = mj_name2id(&m, mjOBJ_BODY, foot);
    const Eigen::Vector3d above(d.xpos[3 * b], d.xpos[3 * b + 1], d.xpos[3 * b + 2] + 0.06);
    for (const sim::OverlayGeom& g : out) {
      if (g.kind == sim::OverlayGeom::Kind::kSphere && (g.from_W - above).norm() < 1e-9 &&
          colour(g))
        ++n;
    }
  }
  return n;
}

}  // namespace

TEST_CASE_METHOD(
    biodyn::testing::SimulationTest,
    "Overlays: a glued foot pulled up shows the red tension flag, honest welds never do",
    "[apps][overlays]") {
  for (const controllers::WeldMode mode :
       {controllers::WeldMode::kGlue, controllers::WeldMode::kHonest}) {
    scenarios::ScenarioConfig config;
    config.scenario = "stand";
    config.weld = mode;
    scenarios::LiveScenario s(config);
    viewer::OverlayBuffers buffers;
    std::vector<sim::OverlayGeom> out;
    s.run_until(1.0);
    viewer::build_overlays(s, viewer::OverlayOptions{}, &buffers, &out);
    const int green_standing = weld_markers(s, out, is_green);
    // Lifting the pelvis harder than the body weighs: a weld that holds a foot down pulls.
    s.push("pelvis", Eigen::Vector3d(0, 0, 1500), 0.3);
    int red = 0, tension_steps = 0;
    while (s.time_s() < 1.3) {
      s.step();
      if (!s.last_report().weld_tension) continue;
      ++tension_steps;
      viewer::build_overlays(s, viewer::OverlayOptions{}, &buffers, &out);
      red = std::max(red, weld_markers(s, out, is_red));
    }
    INFO("weld mode " << controllers::to_string(mode) << ": " << green_standing
                      << " green markers standing, " << tension_steps << " tension steps, " << red
                      << " red markers");
    CHECK(green_standing == 2);  // both feet welded while standing
    if (mode == controllers::WeldMode::kGlue) {
      CHECK(tension_steps > 0);
      CHECK(red >= 1);
    } else {
      CHECK(tension_steps == 0);  // honest mode undoes a step with a weld in tension
      CHECK(red == 0);
    }
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Overlays: one box per stepping stone, the support polygon under the feet",
                 "[apps][overlays][stones]") {
  scenarios::ScenarioConfig config;
  config.scenario = "stones";
  config.speed_m_s = 0.7;
  scenarios::LiveScenario s(config);
  viewer::OverlayBuffers buffers;
  std::vector<sim::OverlayGeom> out;
  s.run_until(9.0);
  viewer::build_overlays(s, viewer::OverlayOptions{}, &buffers, &out);
  // An instant with a foot flat on the floor (on a heel or toe edge the hull is a segment).
  for (double t = 9.02; t < 10.0 && buffers.hull.size() < 3; t += 0.02) {
    s.run_until(t);
    viewer::build_overlays(s, viewer::OverlayOptions{}, &buffers, &out);
  }
  REQUIRE(buffers.hull.size() >= 3);
  int boxes = 0, lines = 0;
  for (const sim::OverlayGeom& g : out) {
    boxes += g.kind == sim::OverlayGeom::Kind::kBox;
    lines += g.kind == sim::OverlayGeom::Kind::kLine;
  }
  CHECK(boxes == static_cast<int>(s.stones().size()));
  CHECK(boxes == 6);
  CHECK(lines >= 3);  // support polygon (and tolerance polygon) edges
  viewer::OverlayOptions none;
  none.stones = false;
  viewer::build_overlays(s, none, &buffers, &out);
  for (const sim::OverlayGeom& g : out) CHECK(g.kind != sim::OverlayGeom::Kind::kBox);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Overlays: each muscle's path is drawn in its activation's colour, the wrapping "
                 "cylinders hidden",
                 "[apps][overlays][muscles]") {
  // The colour scale: grey-blue relaxed, red fully active, redder as the activation grows.
  const std::array<float, 4> relaxed = viewer::activation_rgba(0.0);
  const std::array<float, 4> active = viewer::activation_rgba(1.0);
  CHECK(relaxed[2] > relaxed[0]);
  CHECK((active[0] > 0.9f && active[1] < 0.2f && active[2] < 0.2f));
  CHECK(viewer::activation_rgba(-1.0) == relaxed);  // clamped
  CHECK(viewer::activation_rgba(2.0) == active);
  for (double a = 0.1; a <= 1.0; a += 0.1)
    CHECK(viewer::activation_rgba(a)[0] > viewer::activation_rgba(a - 0.1)[0]);

  scenarios::ScenarioConfig config;
  config.scenario = "walk";
  config.muscles.on = true;
  scenarios::LiveScenario s(config);
  REQUIRE(s.muscles() != nullptr);
  s.run_until(0.6);  // early in the first step: some muscles near full activation, some off
  std::vector<float> activation, rgba;
  viewer::muscle_activations(s, &activation);
  const muscles::MuscleSet& set = s.muscles()->set();
  REQUIRE(static_cast<int>(activation.size()) == set.size());
  CHECK(*std::max_element(activation.begin(), activation.end()) > 0.5f);
  CHECK(*std::min_element(activation.begin(), activation.end()) < 0.1f);
  viewer::tendon_colors(s, activation, &rgba);
  const mjModel& m = s.simulation().model();
  REQUIRE(rgba.size() == 4 * static_cast<std::size_t>(m.ntendon));

  // The scene MuJoCo makes (no GL needed), as the viewer and `biodyn render` set it up.
  mjvScene scene;
  mjv_defaultScene(&scene);
  mjv_makeScene(&m, &scene, 4000);
  mjvOption options;
  mjv_defaultOption(&options);
  options.flags[mjVIS_TENDON] = 0;
  options.geomgroup[3] = 1;
  viewer::muscle_scene_options(s, viewer::OverlayOptions{}, &options);
  CHECK(options.flags[mjVIS_TENDON] == 1);
  CHECK(options.geomgroup[3] == 0);
  mjvCamera camera;
  mjv_defaultCamera(&camera);
  const auto drawn = [&](const mjvOption& o, std::vector<int>* segments, int* wraps) {
    mjv_updateScene(&m, &s.simulation().data(), &o, nullptr, &camera, mjCAT_ALL, &scene);
    sim::recolor_objects(mjOBJ_TENDON, rgba, &scene, viewer::kMusclePathWidthScale);
    segments->assign(static_cast<std::size_t>(m.ntendon), 0);
    *wraps = 0;
    for (int i = 0; i < scene.ngeom; ++i) {
      const mjvGeom& g = scene.geoms[i];
      if (g.objtype == mjOBJ_GEOM && m.geom_group[g.objid] == 3) ++*wraps;
      if (g.objtype != mjOBJ_TENDON) continue;
      ++(*segments)[static_cast<std::size_t>(g.objid)];
      const float* want = rgba.data() + 4 * g.objid;
      CHECK(std::equal(want, want + 4, g.rgba));
      // MuJoCo draws a segment inside a wrapping object half as wide.
      const double width = viewer::kMusclePathWidthScale * m.tendon_width[g.objid];
      CHECK((g.size[0] == Approx(width).epsilon(1e-6) ||
             g.size[0] == Approx(0.5 * width).epsilon(1e-6)));
    }
  };
  std::vector<int> segments;
  int wraps = 0;
  drawn(options, &segments, &wraps);
  CHECK(wraps == 0);
  for (int i = 0; i < set.size(); ++i) {
    INFO(set.params(i).name);
    CHECK(segments[static_cast<std::size_t>(set.tendon(i))] >= 1);  // every muscle's path drawn
    const std::array<float, 4> want =
        viewer::activation_rgba(activation[static_cast<std::size_t>(i)]);
    CHECK(std::equal(want.begin(), want.end(), rgba.begin() + 4 * set.tendon(i)));
  }
  // Shown on request; the muscles off in the panel hide the paths.
  viewer::OverlayOptions shown;
  shown.wrap_cylinders = true;
  shown.muscles = false;
  viewer::muscle_scene_options(s, shown, &options);
  drawn(options, &segments, &wraps);
  CHECK(wraps > 0);
  CHECK(std::accumulate(segments.begin(), segments.end(), 0) == 0);
  mjv_freeScene(&scene);

  // Without muscles: nothing to colour.
  scenarios::LiveScenario plain{scenarios::ScenarioConfig{}};
  viewer::muscle_activations(plain, &activation);
  CHECK(activation.empty());
  viewer::tendon_colors(plain, activation, &rgba);
  CHECK(rgba.empty());
}
