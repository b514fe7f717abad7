// Moment arms of the generated character's muscles (muscles/muscle_set.h, models/muscle_anatomy.h)
// on three bodies: MuJoCo's tendon Jacobian against central differences of the path length over
// each joint's range, nothing on the free root, sparse and dense Jacobians alike, and the
// moment arms inside published ranges.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "biodyn/models/character.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/muscles/muscle_set.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/units.h"
#include "character.h"
#include "test_support.h"

namespace biodyn::muscles::moment_arms_test {
namespace {

constexpr double kDegree = kRadPerDeg;
constexpr double kFdStep_rad = 1e-6;
// Jacobian vs central difference of the length: MuJoCo's tendon Jacobian is exact for a taut
// path (its wrap points slide along the cylinder without changing the length to first order);
// what is left is the difference's rounding (~1e-16 m / 1e-6 rad) and truncation.
constexpr double kMomentArmTolerance_m = 1e-7;
constexpr double kRootTolerance_m = 1e-12;  // root columns: rounding only
constexpr double kHipSweep_rad = 45 * kDegree;
constexpr int kSweepSamples = 46;  // per joint range: steps of 1.5-3 deg

struct Body {
  const char* label;
  double height_m, mass_kg;
  models::Sex sex;
};
const Body kBodies[] = {{"default 1.80 m 80 kg male", 1.80, 80.0, models::Sex::kMale},
                        {"1.55 m 50 kg female", 1.55, 50.0, models::Sex::kFemale},
                        {"1.95 m 120 kg male", 1.95, 120.0, models::Sex::kMale}};

// A generated body with its muscles, compiled, and a scratch mjData to pose it.
class MuscledBody {
 public:
  explicit MuscledBody(const Body& b)
      : character_(generate(b)),
        model_(sim::Model::from_string(models::to_mjcf(character_))),
        data_(*model_),
        set_(*model_, muscle_params(character_.muscles, TendonChoice::kPerMuscle)),
        R_(static_cast<Eigen::Index>(set_.covered_dofs().size()), set_.size()) {}

  const mjModel& m() const { return *model_; }
  mjData& d() { return *data_; }
  const MuscleSet& set() const { return set_; }
  int muscle(const std::string& name) const {
    for (int i = 0; i < set_.size(); ++i)
      if (set_.params(i).name == name) return i;
    FAIL("no muscle " << name);
    return -1;
  }
  int dof(const std::string& joint, int axis = 0) const {
    const int j = mj_name2id(&m(), mjOBJ_JOINT, joint.c_str());
    REQUIRE(j >= 0);
    return m().jnt_dofadr[j] + axis;
  }
  std::string dof_name(int dof) const {
    const int j = m().dof_jntid[dof];
    std::string name = mj_id2name(&m(), mjOBJ_JOINT, j);
    if (m().jnt_type[j] == mjJNT_BALL) name += std::string("_") + "xyz"[dof - m().jnt_dofadr[j]];
    return name;
  }
  bool is_ball(int dof) const { return m().jnt_type[m().dof_jntid[dof]] == mjJNT_BALL; }
  int row(int dof) const {
    const auto& c = set_.covered_dofs();
    return static_cast<int>(std::find(c.begin(), c.end(), dof) - c.begin());
  }

  /// The standing pose with DOF `dof` at `angle` (a ball: rotated by `angle` about its axis),
  /// positions and the tendons computed.
  void pose(int dof, double angle) {
    const mjModel& mm = m();
    // Only the positions matter (mj_resetData would clear all of mjData's ~11 MB arena).
    std::copy(mm.qpos0, mm.qpos0 + mm.nq, d().qpos);
    const int j = mm.dof_jntid[dof], adr = mm.jnt_qposadr[j];
    if (mm.jnt_type[j] == mjJNT_BALL) {
      const int axis = dof - mm.jnt_dofadr[j];
      d().qpos[adr] = std::cos(angle / 2);
      for (int k = 0; k < 3; ++k) d().qpos[adr + 1 + k] = k == axis ? std::sin(angle / 2) : 0.0;
    } else {
      d().qpos[adr] = angle;
    }
    mj_kinematics(&mm, &d());
    mj_comPos(&mm, &d());
    mj_tendon(&mm, &d());
  }
  double length(int muscle, int dof, double angle) {
    pose(dof, angle);
    return set_.length(d(), muscle);
  }
  /// m: r = -dl/dq from the Jacobian (MuscleSet::moment_arms) at `angle`.
  double jacobian_arm(int muscle, int dof, double angle) {
    pose(dof, angle);
    set_.moment_arms(m(), d(), &R_);
    return R_(row(dof), muscle);
  }
  /// m: r = -dl/dq by central differences of MuJoCo's path length.
  double fd_arm(int muscle, int dof, double angle) {
    return -(length(muscle, dof, angle + kFdStep_rad) - length(muscle, dof, angle - kFdStep_rad)) /
           (2 * kFdStep_rad);
  }
  /// Wrapping geoms the muscle's path touches in the present pose.
  int wraps_touched(int muscle) const {
    const int t = set_.tendon(muscle);
    int n = 0;
    for (int w = 0; w < data_->ten_wrapnum[t]; ++w)
      n += data_->wrap_obj[data_->ten_wrapadr[t] + w] >= 0;
    return n;
  }
  /// The DOF's sweep: a hinge over its range, a ball axis over +-45 deg.
  std::pair<double, double> sweep(int dof) const {
    if (is_ball(dof)) return {-kHipSweep_rad, kHipSweep_rad};
    const int j = m().dof_jntid[dof];
    return {m().jnt_range[2 * j], m().jnt_range[2 * j + 1]};
  }

 private:
  static models::Character generate(const Body& b) {
    models::CharacterSpec spec;
    spec.height_m = b.height_m;
    spec.mass_kg = b.mass_kg;
    spec.sex = b.sex;
    spec.detail = models::Detail::kGait;
    return testing::muscled_character(spec);
  }
  models::Character character_;
  sim::Model model_;
  sim::Data data_;
  MuscleSet set_;
  Eigen::MatrixXd R_;
};

}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "moment arms from the tendon Jacobian equal -dl/dq over every joint's range",
                 "[muscles]") {
  for (const Body& b : kBodies) {
    MuscledBody body(b);
    const MuscleSet& set = body.set();
    int compared = 0, at_wrap_switch = 0;
    std::ostringstream switches;
    for (std::size_t k = 0; k < set.covered_dofs().size(); ++k) {
      const int dof = set.covered_dofs()[k];
      const auto [lo, hi] = body.sweep(dof);
      for (int i : set.muscles_of_dof()[k]) {
        for (int s = 0; s <= kSweepSamples; ++s) {
          const double angle = lo + (hi - lo) * s / kSweepSamples;
          // A difference straddling a wrap's on/off switch is not a derivative: skip those.
          body.pose(dof, angle - kFdStep_rad);
          const int wraps_before = body.wraps_touched(i);
          body.pose(dof, angle + kFdStep_rad);
          if (body.wraps_touched(i) != wraps_before) {
            ++at_wrap_switch;
            switches << " " << set.params(i).name << "@" << body.dof_name(dof) << "="
                     << angle / kDegree;
            continue;
          }
          const double jac = body.jacobian_arm(i, dof, angle), fd = body.fd_arm(i, dof, angle);
          INFO(b.label << ": " << set.params(i).name << " about " << body.dof_name(dof) << " at "
                       << angle / kDegree << " deg: Jacobian " << jac << " m, -dl/dq " << fd
                       << " m");
          CHECK(std::abs(jac - fd) < kMomentArmTolerance_m);
          ++compared;
        }
      }
    }
    INFO(b.label << ": skipped at wrap switches:" << switches.str());
    CHECK(compared > 2000);
    CHECK(at_wrap_switch < compared / 100);
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "moment arms: nothing acts on the free root, sparse and dense Jacobians agree",
                 "[muscles]") {
  MuscledBody body(kBodies[0]);
  const mjModel& m = body.m();
  mjData& d = body.d();
  REQUIRE(mj_isSparse(&m));
  const int root_dofs = 6;
  REQUIRE(m.jnt_type[m.dof_jntid[0]] == mjJNT_FREE);
  sim::Model dense_model = sim::Model::from_string(models::to_mjcf(testing::muscled_character()));
  dense_model->opt.jacobian = mjJAC_DENSE;
  sim::Data dense_data(*dense_model);
  const MuscleSet& set = body.set();
  const MuscleSet dense_set(*dense_model, set.params());
  const Eigen::Index rows = static_cast<Eigen::Index>(set.covered_dofs().size());
  Eigen::MatrixXd R_sparse(rows, set.size()), R_dense(rows, set.size());
  std::mt19937 rng(251);
  std::uniform_real_distribution<double> angle(-0.5, 0.5);
  for (int trial = 0; trial < 20; ++trial) {
    mj_resetData(&m, &d);
    // A random pose of every joint, the root moved and turned too.
    for (int i = 0; i < m.nq; ++i) d.qpos[i] += angle(rng);
    mj_normalizeQuat(&m, d.qpos);
    mj_kinematics(&m, &d);
    mj_comPos(&m, &d);
    mj_tendon(&m, &d);
    for (int i = 0; i < set.size(); ++i) {
      const int t = set.tendon(i);
      for (int k = d.ten_J_rowadr[t]; k < d.ten_J_rowadr[t] + d.ten_J_rownnz[t]; ++k) {
        if (d.ten_J_colind[k] >= root_dofs) continue;
        INFO(set.params(i).name << ", root DOF " << d.ten_J_colind[k]);
        CHECK(std::abs(d.ten_J[k]) < kRootTolerance_m);
      }
    }
    set.moment_arms(m, d, &R_sparse);
    mjData& dd = *dense_data;
    std::copy(d.qpos, d.qpos + m.nq, dd.qpos);
    mj_kinematics(dense_model.get(), &dd);
    mj_comPos(dense_model.get(), &dd);
    mj_tendon(dense_model.get(), &dd);
    for (int i = 0; i < set.size(); ++i)
      for (int dof = 0; dof < root_dofs; ++dof)
        CHECK(std::abs(dd.ten_J[set.tendon(i) * m.nv + dof]) < kRootTolerance_m);
    dense_set.moment_arms(*dense_model, dd, &R_dense);
    CHECK((R_sparse - R_dense).cwiseAbs().maxCoeff() < kRootTolerance_m);
    CHECK(R_sparse.cwiseAbs().maxCoeff() > 0.01);  // not all zero
  }
}

namespace {

// What a moment arm r = -dl/dq means anatomically: the sign that makes the named action's
// moment arm positive. Hinges are positive in flexion (knee flexion, ankle dorsiflexion); the hip
// is a ball about the thigh frame's x (forward), y (left), z (up): +y is extension on both sides,
// +x abduction on the left and adduction on the right (the right frame is not mirrored).
enum class Action {
  kKneeExtension,
  kKneeFlexion,
  kPlantarflexion,
  kDorsiflexion,
  kHipAbduction,
  kHipExtension,
  kHipFlexion
};

double action_arm(Action a, bool left, double r) {
  switch (a) {
    case Action::kKneeFlexion:
    case Action::kDorsiflexion:
    case Action::kHipExtension:
      return r;
    case Action::kKneeExtension:
    case Action::kPlantarflexion:
    case Action::kHipFlexion:
      return -r;
    case Action::kHipAbduction:
      return left ? r : -r;
  }
  return 0.0;
}

struct PublishedRange {
  // Base name (both sides are checked), or parts of one muscle joined by '+': their moment arms
  // averaged weighted by F_max, what a whole-muscle measurement sees.
  const char* muscle;
  const char* joint;  // joint name without side
  int axis;           // ball: 0 x, 1 y, 2 z; hinge: 0
  Action action;
  double from_deg, to_deg;  // the joint angle swept (hinge sign convention; ball about axis)
  double min_cm, max_cm;
  const char* source;
};

// Published in-vivo / cadaver / model moment arms of adults (mostly men of ~1.70-1.80 m).
const PublishedRange kPublished[] = {
    // Herzog & Read 1993, J Anat 182:213 (cadaver knees, patellar tendon 3.5-5 cm over 0-90 deg);
    // Buford et al. 1997, IEEE Trans Rehabil Eng 5:367 (quadriceps 3.5-5 cm).
    {"vasti", "knee_flexion", 0, Action::kKneeExtension, 0, 90, 3.0, 5.5,
     "Herzog 1993; Buford 1997"},
    {"rect_fem", "knee_flexion", 0, Action::kKneeExtension, 0, 90, 3.0, 5.5,
     "Herzog 1993; Buford 1997"},
    // Same sources: hamstrings 1.5-3 cm extended, rising to 4-6 cm at 60-90 deg flexion.
    {"hamstrings", "knee_flexion", 0, Action::kKneeFlexion, 0, 90, 2.0, 6.0,
     "Herzog 1993; Buford 1997"},
    // Rugg et al. 1990, J Biomech 23:495 (MRI); Maganaris et al. 1998 J Physiol 510:977 and 2000
    // Eur J Appl Physiol 83:363 (4.3-5.6 cm at rest, 15 deg dorsiflexion to 30 deg plantar);
    // Manal et al. 2013 Physiol Rep 1:e00139 (3.5-3.7 cm, ultrasound).
    {"soleus", "ankle_dorsiflexion", 0, Action::kPlantarflexion, -30, 15, 3.5, 6.0,
     "Rugg 1990; Maganaris 1998, 2000"},
    {"gastroc", "ankle_dorsiflexion", 0, Action::kPlantarflexion, -30, 15, 3.5, 6.0,
     "Rugg 1990; Maganaris 1998, 2000"},
    // Maganaris et al. 1999 Clin Biomech 14:661 / 2000 J Biomech 33:375: ~4.5 cm dorsiflexed to
    // ~2.9 cm plantarflexed at rest, 0.9-1.5 cm more in contraction.
    {"tib_ant", "ankle_dorsiflexion", 0, Action::kDorsiflexion, -30, 15, 3.0, 5.5,
     "Maganaris 1999, 2000"},
    // Delp et al. 1990 IEEE TBME 37:757 (the model Rajagopal 2016 builds on) and Dostal & Andrews
    // 1981 J Biomech 14:803: gluteus medius abduction 4-7 cm at neutral.
    // The whole muscle: its anterior and posterior units together.
    {"glut_med_ant+glut_med_post", "hip", 0, Action::kHipAbduction, 0, 0, 4.0, 7.0,
     "Delp 1990; Dostal 1981"},
    // Nemeth & Ohlsen 1985 J Biomech 18:129 (CT, gluteus maximus 4-8 cm near neutral); Delp 1990.
    {"glut_max", "hip", 1, Action::kHipExtension, 0, 0, 4.0, 8.0, "Nemeth 1985; Delp 1990"},
    // Delp 1990; Arnold et al. 2000 / Blemker & Delp 2005: iliopsoas flexion 1.5-4 cm at neutral.
    {"iliopsoas", "hip", 1, Action::kHipFlexion, 0, 0, 1.5, 4.0, "Delp 1990"},
};

// Muscles whose measured moment arm falls outside its published range on a body: an anatomy
// finding reported (issue 25), not a tolerance. The test checks each is still outside, so fixing
// the anatomy makes it fail here until the entry is removed.
struct KnownOutlier {
  const char* body;
  const char* muscle;
};
const KnownOutlier kKnownOutliers[] = {
    // The 1.55 m woman's segments are shorter than her height alone says (de Leva's female
    // thigh 0.81 and foot 0.80 of the model's, height 0.91): 0.76-0.80 of the default body's arms.
    {"1.55 m 50 kg female", "vasti"},                       // 2.78-3.58 cm < 3.0
    {"1.55 m 50 kg female", "rect_fem"},                    // 2.85-3.82 cm < 3.0
    {"1.55 m 50 kg female", "soleus"},                      // 2.89-3.71 cm < 3.5
    {"1.55 m 50 kg female", "gastroc"},                     // 2.80-3.71 cm < 3.5
    {"1.55 m 50 kg female", "glut_med_ant+glut_med_post"},  // 3.51 cm < 4.0
    {"1.95 m 120 kg male", "tib_ant"},  // 4.25-5.56 cm > 5.5 (at 15 deg dorsiflexion)
};

// cm, the least and greatest moment arm of `pr`'s muscle on one side over its angles (1 deg
// steps), in the sense of its action.
std::pair<double, double> measured_range_cm(MuscledBody* body, const PublishedRange& pr,
                                            bool left) {
  constexpr double kStep_deg = 1.0;
  const char* side = left ? "_l" : "_r";
  std::vector<int> parts;
  std::istringstream names(pr.muscle);
  for (std::string name; std::getline(names, name, '+');)
    parts.push_back(body->muscle(name + side));
  const int dof = body->dof(std::string(pr.joint) + side, pr.axis);
  double lo = 1e9, hi = -1e9;
  for (double deg = pr.from_deg; deg <= pr.to_deg + 1e-9; deg += kStep_deg) {
    double weighted = 0, force = 0;
    for (int i : parts) {
      const double f = body->set().params(i).max_isometric_force_N;
      weighted += f * body->jacobian_arm(i, dof, deg * kDegree);
      force += f;
    }
    const double r = 100.0 * action_arm(pr.action, left, weighted / force);
    lo = std::min(lo, r), hi = std::max(hi, r);
  }
  return {lo, hi};
}

}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "moment arms fall in published ranges on the three bodies", "[muscles]") {
  for (const Body& b : kBodies) {
    MuscledBody body(b);
    for (const PublishedRange& pr : kPublished) {
      bool known = false;
      for (const KnownOutlier& k : kKnownOutliers)
        known = known || (std::string(k.body) == b.label && std::string(k.muscle) == pr.muscle);
      for (const char* side : {"_l", "_r"}) {
        const bool left = side[1] == 'l';
        const auto [lo, hi] = measured_range_cm(&body, pr, left);
        INFO(b.label << ": " << pr.muscle << side << " over [" << pr.from_deg << ", " << pr.to_deg
                     << "] deg: " << lo << "-" << hi << " cm; published " << pr.min_cm << "-"
                     << pr.max_cm << " cm (" << pr.source << ")");
        const bool inside = lo >= pr.min_cm && hi <= pr.max_cm;
        if (known) {
          CHECK_FALSE(inside);  // fixed? remove it from kKnownOutliers
        } else {
          CHECK(inside);
        }
      }
    }
  }
}

namespace {

// Paths known to jump: near the ends of the hip's range a path point passes inside its wrapping
// cylinder, and MuJoCo 2.2.2 drops the wrap there (the straight path cuts through: 1-19 cm shorter
// in one 0.5 deg step). All beyond 29 deg of hip adduction or rotation or 35 deg of extension,
// outside walking and squatting (references.md: hip adduction within 10 deg in gait). Each is
// checked to still jump, so a fix fails here until its entry is removed. {muscle, joint, ball
// axis, body label or nullptr for every body}.
struct KnownJump {
  const char* muscle;
  const char* joint;
  int axis;
  const char* body = nullptr;
};
const KnownJump kKnownJumps[] = {
    {"glut_max", "hip", 0},   // Gmax2_at_pelvis: adduction beyond ~36 deg (woman ~30)
    {"glut_max", "hip", 2},   // Gmax2_at_pelvis: external rotation beyond ~42 deg (woman ~33)
    {"iliopsoas", "hip", 0},  // PS_at_brim: adduction beyond ~44 deg (woman ~37)
    {"iliopsoas", "hip", 1, "1.55 m 50 kg female"},  // PS_at_brim: extension beyond ~35 deg
};

// rad, the angles in `dof`'s sweep where muscle i's path length or moment arm jumps: the length
// changes by more than its moment arms allow over the step (trapezoid), or the moment arm by more
// than a wrap coming on or off can change it.
std::vector<double> jumps(MuscledBody* body, int i, int dof) {
  constexpr double kStep_rad = 0.5 * kDegree;
  constexpr double kLengthJump_m = 1e-3, kArmJump_m = 5e-3;
  const auto [lo, hi] = body->sweep(dof);
  std::vector<double> out;
  double l_prev = 0, r_prev = 0;
  const int n = static_cast<int>(std::round((hi - lo) / kStep_rad));
  for (int s = 0; s <= n; ++s) {
    const double angle = lo + (hi - lo) * s / n;
    const double r = body->jacobian_arm(i, dof, angle);
    const double l = body->set().length(body->d(), i);
    if (s > 0) {
      const double expected = -0.5 * (r + r_prev) * (hi - lo) / n;
      if (std::abs(l - l_prev - expected) > kLengthJump_m || std::abs(r - r_prev) > kArmJump_m)
        out.push_back(angle);
    }
    l_prev = l, r_prev = r;
  }
  return out;
}

}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "path lengths and moment arms are continuous over every joint's range",
                 "[muscles]") {
  for (const Body& b : kBodies) {
    MuscledBody body(b);
    const MuscleSet& set = body.set();
    for (std::size_t k = 0; k < set.covered_dofs().size(); ++k) {
      const int dof = set.covered_dofs()[k];
      for (int i : set.muscles_of_dof()[k]) {
        const std::string& name = set.params(i).name;
        bool known = false;
        for (const KnownJump& j : kKnownJumps) {
          const std::string side = name.substr(name.size() - 2);
          known = known || (name == std::string(j.muscle) + side &&
                            dof == body.dof(std::string(j.joint) + side, j.axis) &&
                            (j.body == nullptr || std::string(j.body) == b.label));
        }
        const std::vector<double> at = jumps(&body, i, dof);
        std::ostringstream where;
        for (double a : at) where << " " << a / kDegree;
        INFO(b.label << ": " << name << " about " << body.dof_name(dof) << " jumps at (deg)"
                     << where.str());
        if (known) {
          CHECK_FALSE(at.empty());  // fixed? remove it from kKnownJumps
        } else {
          CHECK(at.empty());
        }
      }
    }
  }
}

// The muscles' moment arms on the three bodies, min-max over the joint ranges (cm), printed for
// the README: `muscles_test '[report]'`.
TEST_CASE_METHOD(biodyn::testing::SimulationTest, "moment arm report", "[.][report]") {
  for (const Body& b : kBodies) {
    MuscledBody body(b);
    const MuscleSet& set = body.set();
    std::cout << b.label << "\n" << std::fixed << std::setprecision(2);
    for (const PublishedRange& pr : kPublished) {
      const auto [lo, hi] = measured_range_cm(&body, pr, false);
      const auto [lo_l, hi_l] = measured_range_cm(&body, pr, true);
      std::cout << "  published " << std::setw(10) << pr.muscle << " " << std::setw(18) << pr.joint
                << " [" << pr.from_deg << ", " << pr.to_deg << "] deg: right " << lo << "-" << hi
                << " left " << lo_l << "-" << hi_l << " cm (published " << pr.min_cm << "-"
                << pr.max_cm << ")" << (lo < pr.min_cm || hi > pr.max_cm ? "  OUTSIDE" : "")
                << "\n";
    }
    std::cout << std::defaultfloat;
    for (int i = 0; i < set.size(); ++i) {
      const std::string& name = set.params(i).name;
      if (name.back() != 'r' && name.back() != 'l') continue;
      for (std::size_t k = 0; k < set.covered_dofs().size(); ++k) {
        const auto& of = set.muscles_of_dof()[k];
        if (std::find(of.begin(), of.end(), i) == of.end()) continue;
        const int dof = set.covered_dofs()[k];
        const auto [lo, hi] = body.sweep(dof);
        double rmin = 1e9, rmax = -1e9, worst = 0;
        std::ostringstream wraps;
        int previous_wraps = -1;
        for (int s = 0; s <= 140; ++s) {
          const double angle = lo + (hi - lo) * s / 140;
          const double r = body.jacobian_arm(i, dof, angle);
          const int w = body.wraps_touched(i);
          if (previous_wraps >= 0 && w != previous_wraps)
            wraps << " " << w << "@" << std::setprecision(3) << angle / kDegree;
          previous_wraps = w;
          rmin = std::min(rmin, r), rmax = std::max(rmax, r);
          worst = std::max(worst, std::abs(r - body.fd_arm(i, dof, angle)));
        }
        body.pose(dof, 0.0);
        std::cout << "  " << std::setw(12) << name << " " << std::setw(22) << body.dof_name(dof)
                  << std::fixed << std::setprecision(0) << " [" << std::setw(4) << lo / kDegree
                  << ", " << std::setw(4) << hi / kDegree << "] deg: r(0) " << std::setprecision(2)
                  << std::setw(6) << 100 * body.jacobian_arm(i, dof, 0.0) << ", min "
                  << std::setw(6) << 100 * rmin << ", max " << std::setw(6) << 100 * rmax
                  << " cm; |J - FD| " << std::scientific << std::setprecision(1) << worst
                  << " m; wraps change:" << std::defaultfloat << wraps.str() << "\n";
      }
    }
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "gastrocnemius stays a knee flexor a little past the knee's extension limit",
                 "[muscles]") {
  // A standing knee sits on its 0 deg limit, and the limit's soft constraint lets it go a few
  // degrees past: the path must stay behind the knee axis there (the side site's job).
  constexpr double kPastLimit_deg = -5.0;
  constexpr double kMinFlexorArm_m = 0.015;
  const models::Character c = testing::muscled_character();
  const sim::Model model = sim::Model::from_string(models::to_mjcf(c));
  const mjModel& m = *model;
  sim::Data data(m);
  const MuscleSet set(m, muscle_params(c.muscles, TendonChoice::kPerMuscle));
  for (const char* side : {"l", "r"}) {
    const int knee = mj_name2id(&m, mjOBJ_JOINT, (std::string("knee_flexion_") + side).c_str());
    REQUIRE(knee >= 0);
    mj_resetData(&m, data.get());
    data->qpos[m.jnt_qposadr[knee]] = kPastLimit_deg * kDegree;
    mj_forward(&m, data.get());
    Eigen::MatrixXd R(static_cast<int>(set.covered_dofs().size()), set.size());
    set.moment_arms(m, *data, &R);
    const auto row =
        std::find(set.covered_dofs().begin(), set.covered_dofs().end(), m.jnt_dofadr[knee]) -
        set.covered_dofs().begin();
    int gastroc = -1;
    for (int i = 0; i < set.size(); ++i)
      if (set.params(i).name == std::string("gastroc_") + side) gastroc = i;
    REQUIRE(gastroc >= 0);
    INFO("gastroc_" << side << " knee moment arm at " << kPastLimit_deg
                    << " deg: " << R(static_cast<int>(row), gastroc) << " m");
    CHECK(R(static_cast<int>(row), gastroc) > kMinFlexorArm_m);
  }
}

}  // namespace biodyn::muscles::moment_arms_test
