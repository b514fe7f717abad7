#include "biodyn/muscles/muscle_set.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <set>

#include "biodyn/sim/errors.h"

namespace biodyn::muscles {
namespace {

using nlohmann::json;

constexpr double kPi = 3.14159265358979323846;
// deg, MuscleParams::validate()'s bound on pennation_at_optimal_rad (1.2 rad), in the unit the
// parameter files use.
constexpr double kMaxPennationAtOptimal_deg = 1.2 * 180 / kPi;

std::vector<int> ancestors_and_self(const mjModel& m, int body) {
  std::vector<int> chain;
  for (int b = body; b > 0; b = m.body_parentid[b]) chain.push_back(b);
  chain.push_back(0);
  return chain;
}

// The DOFs between the bodies a tendon's path touches: each body's joints up to (not including)
// the lowest common ancestor of them all.
std::vector<int> spanned_dofs(const mjModel& m, int tendon) {
  std::vector<int> bodies;
  for (int w = m.tendon_adr[tendon]; w < m.tendon_adr[tendon] + m.tendon_num[tendon]; ++w) {
    if (m.wrap_type[w] == mjWRAP_SITE) bodies.push_back(m.site_bodyid[m.wrap_objid[w]]);
  }
  std::vector<int> common = ancestors_and_self(m, bodies.front());
  for (int b : bodies) {
    const std::vector<int> chain = ancestors_and_self(m, b);
    common.erase(std::remove_if(common.begin(), common.end(),
                                [&](int c) {
                                  return std::find(chain.begin(), chain.end(), c) == chain.end();
                                }),
                 common.end());
  }
  const int lca = common.front();
  std::set<int> dofs;
  for (int b : bodies) {
    for (int c = b; c != lca && c > 0; c = m.body_parentid[c]) {
      for (int k = 0; k < m.body_dofnum[c]; ++k) dofs.insert(m.body_dofadr[c] + k);
    }
  }
  return {dofs.begin(), dofs.end()};
}

void set_field(MuscleParams* p, const MuscleParams& table, const std::string& where,
               const std::string& key, const json& v) {
  const auto number = [&]() {
    if (!v.is_number()) {
      throw sim::InvalidArgument(where + "." + key + ": must be a number, got " + v.dump());
    }
    const double x = v.get<double>();
    if (!std::isfinite(x)) throw sim::InvalidArgument(where + "." + key + ": must be finite");
    return x;
  };
  if (key == "max_isometric_force_N")
    p->max_isometric_force_N = number();
  else if (key == "scale_max_isometric_force") {
    const double s = number();
    if (!(s > 0 && s <= 10)) {
      throw sim::InvalidArgument(where + "." + key + ": must be in (0, 10], got " + v.dump());
    }
    p->max_isometric_force_N = table.max_isometric_force_N * s;  // of the table's, not compounded
  } else if (key == "optimal_fiber_length_m")
    p->optimal_fiber_length_m = number();
  else if (key == "tendon_slack_length_m")
    p->tendon_slack_length_m = number();
  else if (key == "pennation_at_optimal_deg") {
    // Checked here in the file's unit: validate() would name the radians, not what was written.
    const double deg = number();
    if (!(deg >= 0 && deg <= kMaxPennationAtOptimal_deg)) {
      throw sim::InvalidArgument(where + "." + key + ": must be in [0, " +
                                 std::to_string(kMaxPennationAtOptimal_deg) + "] deg, got " +
                                 v.dump());
    }
    p->pennation_at_optimal_rad = deg * kPi / 180;
  } else if (key == "max_contraction_velocity_lopt_per_s")
    p->max_contraction_velocity_lopt_per_s = number();
  else if (key == "activation_time_constant_s")
    p->activation_time_constant_s = number();
  else if (key == "deactivation_time_constant_s")
    p->deactivation_time_constant_s = number();
  else if (key == "min_activation")
    p->min_activation = number();
  else if (key == "fiber_damping")
    p->fiber_damping = number();
  else if (key == "tendon") {
    if (!v.is_string()) {
      throw sim::InvalidArgument(where + ".tendon: must be \"rigid\" or \"compliant\", got " +
                                 v.dump());
    }
    p->tendon = parse_tendon_model(v.get<std::string>(), where + ".tendon");
  } else {
    throw sim::InvalidArgument(where + ": unknown field '" + key +
                               "' (max_isometric_force_N, scale_max_isometric_force, "
                               "optimal_fiber_length_m, tendon_slack_length_m, "
                               "pennation_at_optimal_deg, max_contraction_velocity_lopt_per_s, "
                               "activation_time_constant_s, deactivation_time_constant_s, "
                               "min_activation, fiber_damping, tendon)");
  }
}

}  // namespace

TendonChoice parse_tendon_choice(const std::string& text, const std::string& field) {
  if (text == "default") return TendonChoice::kPerMuscle;
  if (text == "rigid") return TendonChoice::kAllRigid;
  if (text == "compliant") return TendonChoice::kAllCompliant;
  throw sim::InvalidArgument(field + ": must be default, rigid or compliant, got '" + text + "'");
}

const char* to_string(TendonChoice choice) {
  switch (choice) {
    case TendonChoice::kPerMuscle:
      return "default (compliant soleus and gastrocnemius)";
    case TendonChoice::kAllRigid:
      return "rigid";
    case TendonChoice::kAllCompliant:
      return "compliant";
  }
  return "?";
}

std::vector<MuscleParams> muscle_params(const std::vector<models::MuscleDefinition>& muscles,
                                        TendonChoice tendons) {
  std::vector<MuscleParams> out;
  for (const models::MuscleDefinition& d : muscles) {
    MuscleParams p;
    p.name = d.name;
    p.max_isometric_force_N = d.max_isometric_force_N;
    p.optimal_fiber_length_m = d.optimal_fiber_length_m;
    p.tendon_slack_length_m = d.tendon_slack_length_m;
    p.pennation_at_optimal_rad = d.pennation_at_optimal_rad;
    p.curves.passive_strain_at_fmax = d.passive_strain_at_fmax;
    p.tendon = tendons == TendonChoice::kAllRigid       ? TendonModel::kRigid
               : tendons == TendonChoice::kAllCompliant ? TendonModel::kCompliant
                                                        : parse_tendon_model(d.tendon, d.name);
    out.push_back(p);
  }
  return out;
}

void apply_muscle_overrides(const std::string& json_text, const std::string& source,
                            std::vector<MuscleParams>* params) {
  json doc;
  try {
    doc = json::parse(json_text);
  } catch (const json::exception& e) {
    throw sim::InvalidArgument(source + ": not valid JSON: " + e.what());
  }
  if (!doc.is_object() || !doc.contains("muscles") || !doc["muscles"].is_object()) {
    throw sim::InvalidArgument(source + ": expected {\"muscles\": {\"<muscle>\": {...}}}");
  }
  // Side-less names first, then side-specific ones (which win), on a copy: a file refused
  // halfway changes nothing.
  std::vector<MuscleParams> out = *params;
  const auto side_specific = [&](const std::string& name) {
    for (const MuscleParams& p : out)
      if (p.name == name) return true;
    return false;
  };
  for (const bool specific : {false, true}) {
    for (const auto& [name, fields] : doc["muscles"].items()) {
      if (side_specific(name) != specific) continue;
      const std::string where = source + ": muscles." + name;
      if (!fields.is_object()) throw sim::InvalidArgument(where + ": must be an object");
      bool matched = false;
      for (std::size_t i = 0; i < out.size(); ++i) {
        MuscleParams& p = out[i];
        if (p.name != name && p.name != name + "_l" && p.name != name + "_r") continue;
        matched = true;
        for (const auto& [key, value] : fields.items())
          set_field(&p, (*params)[i], where, key, value);
        try {
          p.validate();
        } catch (const sim::InvalidArgument& e) {
          throw sim::InvalidArgument(source + ": " + e.what());
        }
      }
      if (!matched) {
        std::string names;
        for (const MuscleParams& p : out) names += (names.empty() ? "" : ", ") + p.name;
        throw sim::InvalidArgument(where + ": no muscle named '" + name + "' (muscles: " + names +
                                   "; a name without _l/_r applies to both sides)");
      }
    }
  }
  *params = std::move(out);
}

MuscleSet::MuscleSet(const mjModel& m, std::vector<MuscleParams> params)
    : params_(std::move(params)), row_of_dof_(static_cast<std::size_t>(m.nv), -1) {
  std::set<int> covered;
  std::vector<std::vector<int>> dofs_of_muscle;
  for (const MuscleParams& p : params_) {
    p.validate();
    const int t = mj_name2id(&m, mjOBJ_TENDON, p.name.c_str());
    if (t < 0) {
      throw sim::InvalidArgument("muscle " + p.name +
                                 ": the model has no spatial tendon of that name (generate the "
                                 "character with muscles: biodyn model --muscles)");
    }
    tendons_.push_back(t);
    dofs_of_muscle.push_back(spanned_dofs(m, t));
    covered.insert(dofs_of_muscle.back().begin(), dofs_of_muscle.back().end());
  }
  covered_.assign(covered.begin(), covered.end());
  muscles_of_dof_.resize(covered_.size());
  for (std::size_t k = 0; k < covered_.size(); ++k)
    row_of_dof_[static_cast<std::size_t>(covered_[k])] = static_cast<int>(k);
  spans_ = Eigen::Matrix<char, Eigen::Dynamic, Eigen::Dynamic>::Zero(
      static_cast<int>(covered_.size()), size());
  for (std::size_t i = 0; i < dofs_of_muscle.size(); ++i) {
    for (int dof : dofs_of_muscle[i]) {
      const int row = row_of_dof_[static_cast<std::size_t>(dof)];
      muscles_of_dof_[static_cast<std::size_t>(row)].push_back(static_cast<int>(i));
      spans_(row, static_cast<int>(i)) = 1;
    }
  }
}

void MuscleSet::moment_arms(const mjModel& m, const mjData& d, Eigen::MatrixXd* R) const {
  R->setZero();
  for (int i = 0; i < size(); ++i) {
    const int t = tendons_[static_cast<std::size_t>(i)];
    if (mj_isSparse(&m)) {
      const int adr = d.ten_J_rowadr[t];
      for (int k = 0; k < d.ten_J_rownnz[t]; ++k) {
        const int row = row_of_dof_[static_cast<std::size_t>(d.ten_J_colind[adr + k])];
        if (row >= 0 && spans_(row, i) != 0) (*R)(row, i) = -d.ten_J[adr + k];
      }
    } else {
      for (std::size_t k = 0; k < covered_.size(); ++k) {
        if (spans_(static_cast<int>(k), i) != 0)
          (*R)(static_cast<int>(k), i) = -d.ten_J[t * m.nv + covered_[k]];
      }
    }
  }
}

void MuscleSet::add_generalized_force(const Eigen::MatrixXd& R, const double* tension_N,
                                      double* qfrc) const {
  for (std::size_t k = 0; k < covered_.size(); ++k) {
    double tau = 0;
    for (int i : muscles_of_dof_[k]) tau += R(static_cast<int>(k), i) * tension_N[i];
    qfrc[covered_[k]] += tau;
  }
}

}  // namespace biodyn::muscles
