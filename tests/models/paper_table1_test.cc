// The paper's Table 1 (male, 179.9 cm, 82.2 kg, gait model) against biodyn's generator.
//
// biodyn uses de Leva (1996) instead of the NASA data the paper cites, so segment masses
// differ, and this test pins how much and why (a change in the tables shows up here):
// - Pelvis ("hip" in the paper): de Leva's lower trunk is OMPH->hip joints, 11.17% of body mass
//   (9.2 kg); the paper gives 16.3 kg, evidently counting the upper thighs/buttocks with the
//   pelvis. Its thigh is correspondingly lighter: 8.3 kg against de Leva's 14.16% (11.6 kg).
// - Trunk: head, arms and the upper two trunk parts together match the paper's 40 kg within 2%.
// - Calf, foot, toe: within ~15% (different cadaver samples; toe share taken from the paper).
// - The paper's masses add up to 83.0 kg, not the 82.2 kg it states.
// - Lengths: thigh and calf within 5% (de Leva's landmarks: hip joint centre to knee, knee to
//   lateral malleolus). The paper's "hip" length (21.09 cm) and trunk length (40.9 cm) measure
//   something else (pelvis breadth, trunk without the head): we compare neither.

#include "biodyn/models/character.h"
#include "test_support.h"

using namespace biodyn::models;

namespace {
struct PaperRow {
  const char* segment;
  double length_cm;         // Table 1
  double mass_kg;           // Table 1
  double our_mass_ratio;    // ours / paper, as measured and explained above
  double our_length_ratio;  // ours / paper, 0 = not comparable
};
constexpr double kRatioTolerance = 0.02;
}  // namespace

TEST_CASE("Generator versus the paper's Table 1 (179.9 cm, 82.2 kg)", "[models][paper]") {
  CharacterSpec spec;
  spec.height_m = 1.799;
  spec.mass_kg = 82.2;
  spec.detail = Detail::kGait;
  const Character c = generate_character(spec);
  const PaperRow rows[] = {
      {"trunk", 40.9, 40.0, 1.01, 0},        {"pelvis", 21.09, 16.3, 0.563, 0},
      {"thigh_l", 45.85, 8.3, 1.402, 0.952}, {"shank_l", 45.05, 4.04, 0.881, 0.996},
      {"foot_l", 19.0, 0.86, 1.115, 1.063},  {"toes_l", 6.1, 0.15, 1.115, 1.063},
  };
  double paper_total = 0;
  for (const PaperRow& r : rows) {
    const Segment* s = c.find(r.segment);
    REQUIRE(s != nullptr);
    INFO(r.segment << ": ours " << s->mass_kg << " kg, " << s->length_m * 100 << " cm");
    CHECK(s->mass_kg / r.mass_kg == Approx(r.our_mass_ratio).margin(kRatioTolerance));
    if (r.our_length_ratio > 0) {
      CHECK(s->length_m * 100 / r.length_cm == Approx(r.our_length_ratio).margin(kRatioTolerance));
    }
    paper_total += r.mass_kg * (std::string(r.segment).find("_l") != std::string::npos ? 2 : 1);
  }
  CHECK(paper_total == Approx(83.0).margin(0.01));
  CHECK(c.total_mass_kg() == Approx(82.2).margin(1e-9));
  // Table 2 torques at the reference subject are the paper's own numbers (scale 1).
  CHECK(c.torque_scale == Approx(1.0).margin(1e-12));
  CHECK(c.find("shank_l")->joints.at(0).tau_max_Nm.x() == Approx(600));
  CHECK(c.find("trunk")->joints.at(1).tau_max_Nm.x() == Approx(300));
}
