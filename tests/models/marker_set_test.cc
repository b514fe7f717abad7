// Built-in marker sets as data: every left/right pair sits mirror-symmetric on the generated
// character (issue 24: walking5's RASI and RPSI once sat on the left of the pelvis, which turned
// the IK's pelvis by 17 deg).
#include "biodyn/models/marker_set.h"

#include <Eigen/Core>
#include <map>
#include <string>

#include "test_support.h"

using namespace biodyn;

namespace {

/// The marker's mirror partner by the usual naming (LASI <-> RASI), or "" when it has none.
std::string mirror_name(const std::string& name) {
  if (name.size() < 2) return "";
  if (name[0] == 'L') return "R" + name.substr(1);
  if (name[0] == 'R') return "L" + name.substr(1);
  return "";
}

}  // namespace

TEST_CASE("built-in marker sets: left and right markers are mirror images", "[models][markers]") {
  for (const std::string& set_name : models::builtin_marker_set_names()) {
    const models::MarkerSet set = models::builtin_marker_set(set_name);
    models::CharacterSpec spec;
    spec.markers = set.markers;
    const models::Character c = models::generate_character(spec);
    std::map<std::string, Eigen::Vector3d> standing;
    std::map<std::string, bool> midline;  // on the pelvis, trunk or head: the side is the name's
    for (const models::Marker& m : c.markers) {
      standing[m.name] = c.find(m.segment)->origin_W + m.position_B;
      const std::string side = m.segment.size() > 2 ? m.segment.substr(m.segment.size() - 2) : "";
      midline[m.name] = side != "_l" && side != "_r";
    }
    int pairs = 0;
    for (const auto& [name, p] : standing) {
      const auto partner = standing.find(mirror_name(name));
      if (partner == standing.end()) continue;
      ++pairs;
      const Eigen::Vector3d mirrored(partner->second.x(), -partner->second.y(),
                                     partner->second.z());
      INFO(set_name << ": " << name << " at " << p.transpose() << ", " << partner->first
                    << " mirrored at " << mirrored.transpose());
      CHECK((p - mirrored).norm() < 1e-9);
      if (midline.at(name)) CHECK((name[0] == 'L') == (p.y() > 1e-3));
    }
    INFO(set_name);
    CHECK(pairs >= 8);
  }
}

TEST_CASE("opensim_walking5: the virtual joint centres are fixed on the joints",
          "[models][markers]") {
  const models::MarkerSet set = models::builtin_marker_set("opensim_walking5");
  models::CharacterSpec spec;
  spec.markers = set.markers;
  const models::Character c = models::generate_character(spec);
  const std::map<std::string, std::string> on_joint = {{"LHJC", "thigh_l"}, {"RHJC", "thigh_r"},
                                                       {"LKJC", "shank_l"}, {"RKJC", "shank_r"},
                                                       {"LAJC", "foot_l"},  {"RAJC", "foot_r"}};
  for (const auto& [name, distal] : on_joint) {
    INFO(name);
    CHECK(set.fixed.count(name) == 1);
    CHECK(set.weight(name) > 1.0);
    for (const models::Marker& m : c.markers) {
      if (m.name != name) continue;
      CHECK((c.find(m.segment)->origin_W + m.position_B - c.find(distal)->origin_W).norm() < 1e-9);
    }
  }
}
