// What the viewer and `biodyn render` draw over the character (viewer/overlays.h): the weld
// markers (green when on, red for a weld in tension), the stones, the support polygon.
#include "biodyn/viewer/overlays.h"
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
