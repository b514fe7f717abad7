// Overlays of the live scenario (overlays.h).
#include "biodyn/viewer/overlays.h"

#include <algorithm>
#include <cmath>

#include "biodyn/controllers/support_polygon.h"
#include "biodyn/muscles/muscle_drive.h"
#include "biodyn/sim/queries.h"

namespace biodyn::viewer {
namespace {

/// m above the floor: polygons drawn just over it so the floor does not hide them.
constexpr double kLift_m = 0.004;
/// A muscle's colour relaxed and fully active (activation_rgba).
constexpr std::array<float, 4> kRelaxed = {0.42f, 0.5f, 0.62f, 1.0f};
constexpr std::array<float, 4> kActive = {1.0f, 0.1f, 0.05f, 1.0f};
/// The models' wrapping cylinders' geom group (models/src/mjcf.cc: hidden unless shown).
constexpr int kWrapGeomGroup = 3;

void polygon(const std::vector<Eigen::Vector2d>& p, const float rgba[4], double width,
             std::vector<sim::OverlayGeom>* out) {
  if (p.size() < 2) return;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Eigen::Vector2d& a = p[i];
    const Eigen::Vector2d& b = p[(i + 1) % p.size()];
    sim::OverlayGeom g;
    g.kind = sim::OverlayGeom::Kind::kLine;
    g.from_W = Eigen::Vector3d(a.x(), a.y(), kLift_m);
    g.to_W = Eigen::Vector3d(b.x(), b.y(), kLift_m);
    g.width_m = width;
    std::copy(rgba, rgba + 4, g.rgba);
    out->push_back(g);
  }
}

}  // namespace

void foot_support(const mjModel& m, const mjData& d, const models::Rig& rig, OverlayBuffers* b) {
  const int feet[4] = {rig.leg(models::kLeft).foot, rig.leg(models::kRight).foot,
                       rig.leg(models::kLeft).toes, rig.leg(models::kRight).toes};
  sim::floor_contacts(m, d, rig.floor_geom(), &b->contacts);
  controllers::contact_support_polygon(b->contacts, feet, 4, &b->points, &b->hull);
}

void build_overlays(const scenarios::LiveScenario& s, const OverlayOptions& o, OverlayBuffers* b,
                    std::vector<sim::OverlayGeom>* out) {
  out->clear();
  const mjModel& m = s.simulation().model();
  const mjData& d = s.simulation().data();
  foot_support(m, d, s.rig(), b);
  static constexpr float kSupport[4] = {0.2f, 0.8f, 0.3f, 1.0f};
  static constexpr float kTolerance[4] = {0.95f, 0.75f, 0.1f, 1.0f};
  static constexpr float kCom[4] = {0.9f, 0.1f, 0.9f, 1.0f};
  static constexpr float kForce[4] = {0.2f, 0.6f, 1.0f, 0.8f};
  static constexpr float kPush[4] = {1.0f, 0.15f, 0.1f, 1.0f};
  if (o.support_polygon) polygon(b->hull, kSupport, 0.006, out);
  if (o.tolerance_polygon && s.gait() != nullptr) {
    polygon(s.gait()->tolerance_polygon(), kTolerance, 0.004, out);
  }
  if (o.com_projection) {
    const sim::CenterOfMass com = sim::center_of_mass(m, d);
    sim::OverlayGeom g;
    g.kind = sim::OverlayGeom::Kind::kSphere;
    g.from_W = Eigen::Vector3d(com.position_W.x(), com.position_W.y(), kLift_m);
    g.width_m = 0.025;
    std::copy(kCom, kCom + 4, g.rgba);
    out->push_back(g);
  }
  if (o.contact_forces) {
    for (const sim::FloorContact& c : b->contacts) {
      const Eigen::Vector3d f = c.normal_force * c.normal_W + c.tangential_force_W;
      if (f.norm() < 1.0) continue;
      sim::OverlayGeom g;
      g.kind = sim::OverlayGeom::Kind::kArrow;
      g.from_W = c.position_W;
      g.to_W = c.position_W + o.force_scale_m_per_N * f;
      g.width_m = 0.006;
      std::copy(kForce, kForce + 4, g.rgba);
      out->push_back(g);
    }
  }
  if (o.pushes) {
    for (const sim::Push& p : s.pushes()) {
      if (d.time < p.start_s || d.time >= p.start_s + p.duration_s) continue;
      const Eigen::Vector3d at(d.xipos + 3 * p.body);
      // The arrow ends at the body: it shows where the push comes from.
      sim::OverlayGeom g;
      g.kind = sim::OverlayGeom::Kind::kArrow;
      g.from_W = at - o.force_scale_m_per_N * p.force_W - 0.1 * p.force_W.normalized();
      g.to_W = at;
      g.width_m = 0.02;
      std::copy(kPush, kPush + 4, g.rgba);
      out->push_back(g);
    }
  }
  if (o.stones) {
    static constexpr float kStone[4] = {0.55f, 0.55f, 0.52f, 1.0f};
    static constexpr float kStoneHit[4] = {0.25f, 0.7f, 0.35f, 1.0f};
    static constexpr float kStoneMissed[4] = {0.95f, 0.55f, 0.1f, 1.0f};
    constexpr double kHit_m = 0.02, kThick_m = 0.003;
    // A stone's outline in the ankle's frame: the sole from heel to toe tips, 1 cm around.
    constexpr double kMargin_m = 0.01;
    const models::Sole& sole = s.rig().leg(models::kLeft).sole;
    const double back = sole.x_min - kMargin_m, front = sole.x_max + kMargin_m;
    const double half_width = 0.5 * (sole.y_max - sole.y_min) + kMargin_m;
    for (const scenarios::Stone& st : s.stones()) {
      const double mid = 0.5 * (back + front);
      const Eigen::Vector2d along(std::cos(st.heading_rad), std::sin(st.heading_rad));
      const Eigen::Vector2d c = st.ankle_W + mid * along;
      sim::OverlayGeom g;
      g.kind = sim::OverlayGeom::Kind::kBox;
      // Short steps put a stone over the other foot's last one: the right foot's stand 1 mm
      // higher so the two do not flicker through each other.
      const double half_thick = kThick_m + 0.001 * st.side;
      g.from_W = Eigen::Vector3d(c.x(), c.y(), half_thick);
      g.half_size_m = Eigen::Vector3d(0.5 * (front - back), half_width, half_thick);
      g.yaw_rad = st.heading_rad;
      const float* rgba = std::isnan(st.walked_m)                         ? kStone
                          : std::abs(st.walked_m - st.target_m) <= kHit_m ? kStoneHit
                                                                          : kStoneMissed;
      std::copy(rgba, rgba + 4, g.rgba);
      out->push_back(g);
    }
  }
  if (o.welds) {
    const controllers::StepReport& r = s.last_report();
    for (int side = 0; side < 2; ++side) {
      if (!r.weld_active[static_cast<std::size_t>(side)]) continue;
      const int body = s.rig().leg(side).foot;
      sim::OverlayGeom g;
      g.kind = sim::OverlayGeom::Kind::kSphere;
      g.from_W =
          Eigen::Vector3d(d.xpos[3 * body], d.xpos[3 * body + 1], d.xpos[3 * body + 2] + 0.06);
      g.width_m = 0.018;
      const float on[4] = {0.1f, 0.9f, 0.1f, 1.0f}, tension[4] = {1.0f, 0.0f, 0.0f, 1.0f};
      std::copy(r.weld_tension ? tension : on, (r.weld_tension ? tension : on) + 4, g.rgba);
      out->push_back(g);
    }
  }
}

std::array<float, 4> activation_rgba(double a) {
  const float t = static_cast<float>(std::clamp(std::isfinite(a) ? a : 0.0, 0.0, 1.0));
  std::array<float, 4> c{};
  for (std::size_t k = 0; k < 4; ++k) c[k] = kRelaxed[k] + t * (kActive[k] - kRelaxed[k]);
  return c;
}

void muscle_activations(const scenarios::LiveScenario& s, std::vector<float>* out) {
  const muscles::MuscleDrive* drive = s.muscles();
  if (drive == nullptr) {
    out->clear();
    return;
  }
  const std::vector<double>& a = drive->state().activation;
  out->resize(a.size());
  std::transform(a.begin(), a.end(), out->begin(), [](double v) { return static_cast<float>(v); });
}

void tendon_colors(const scenarios::LiveScenario& s, const std::vector<float>& activation,
                   std::vector<float>* out) {
  const muscles::MuscleDrive* drive = s.muscles();
  if (drive == nullptr || activation.empty()) {
    out->clear();
    return;
  }
  const muscles::MuscleSet& set = drive->set();
  out->assign(4 * static_cast<std::size_t>(s.simulation().model().ntendon), -1.0f);
  const int n = std::min(set.size(), static_cast<int>(activation.size()));
  for (int i = 0; i < n; ++i) {
    const std::array<float, 4> c = activation_rgba(activation[static_cast<std::size_t>(i)]);
    std::copy(c.begin(), c.end(), out->begin() + 4 * static_cast<std::ptrdiff_t>(set.tendon(i)));
  }
}

void color_muscles(const std::vector<float>& tendon_rgba, sim::SceneRenderer* renderer) {
  renderer->recolor(mjOBJ_TENDON, tendon_rgba, kMusclePathWidthScale);
}

void muscle_scene_options(const scenarios::LiveScenario& s, const OverlayOptions& o,
                          mjvOption* options) {
  if (s.muscles() != nullptr) {
    options->flags[mjVIS_TENDON] = o.muscles ? 1 : 0;
    options->flags[mjVIS_TRANSPARENT] = o.muscles ? 1 : 0;
  }
  options->geomgroup[kWrapGeomGroup] = o.wrap_cylinders ? 1 : 0;
}

}  // namespace biodyn::viewer
