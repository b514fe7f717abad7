// `biodyn evaluate`: a captured motion on a list of bodies (evaluate.h).
#include "biodyn/scenarios/evaluate.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "biodyn/mocap_io/bvh.h"
#include "biodyn/mocap_io/inverse_dynamics.h"
#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/mocap_io/retarget.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/muscles/muscle_set.h"
#include "biodyn/muscles/static_optimization.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/queries.h"

namespace biodyn::scenarios {
namespace {

using nlohmann::json;

/// "heavy_trunk_thighs": this much more of the body's mass in the trunk parts and the thighs
/// (the other segments share the rest: SegmentOverride).
constexpr double kHeavyProfileFactor = 1.25;
/// s: a joint saturates when its torque stays above tau_max this long (a frame or two above it
/// is a kinematic glitch's spike, e.g. the CMU clip's pelvis jumping 2.4 cm in 25 ms).
constexpr double kSustained_s = 0.05;

/// The body's character: its spec with the profile's mass distribution and the tau_max rule
/// applied (kFixed: the reference body's torque scale).
models::Character body_character(const EvaluationBody& b, const models::CharacterSpec& reference) {
  models::CharacterSpec spec = b.spec;
  spec.muscles = true;  // the legs' muscle paths for static optimisation (no dynamics change)
  if (b.profile == "heavy_trunk_thighs") {
    const models::Character plain = models::generate_character(spec);
    for (const models::Segment& s : plain.segments) {
      const bool heavy = s.name == "lumbar" || s.name == "thorax" || s.name == "trunk" ||
                         s.name.rfind("thigh", 0) == 0;
      if (heavy) spec.overrides[s.name].mass_kg = kHeavyProfileFactor * s.mass_kg;
    }
  }
  if (b.tau_rule == TauMaxRule::kFixed) {
    // The reference body's torque scale on this body (paper §5.1 scales by mass and height).
    spec.tau_max_factor = models::torque_scale(reference) / models::torque_scale(spec);
  }
  models::Character c = models::generate_character(spec);
  return c;
}

/// The motion on `target` (compiled `model`): a BVH retargeted to it; a qpos CSV of the same
/// geometry as is (joint angles hold on any mass), else through its body's BVH, retargeted.
mocap_io::Motion motion_on_body(const std::string& path, const models::Character& target,
                                const mjModel& model) {
  const std::string ext = std::filesystem::path(path).extension().string();
  mocap_io::BvhMotion bvh;
  if (ext == ".bvh" || ext == ".BVH") {
    bvh = mocap_io::read_bvh(path);
  } else {
    // An IK motion's unsolved frames (NaN rows) are left out: its longest solved run.
    const mocap_io::Motion source = mocap_io::longest_solved_span(mocap_io::read_motion_csv(path));
    const std::optional<models::CharacterSpec> body = mocap_io::motion_body(source, path);
    if (!body) {
      throw sim::InvalidArgument(path +
                                 ": a qpos CSV for evaluate needs its body in the header "
                                 "(# body: ..., as mocap ik and retarget write)");
    }
    models::CharacterSpec same = *body;
    same.mass_kg = target.spec.mass_kg;
    same.muscles = target.spec.muscles;
    same.overrides = target.spec.overrides;
    if (same.height_m == target.spec.height_m && same.sex == target.spec.sex &&
        same.detail == target.spec.detail && body->overrides.empty()) {
      mocap_io::check_motion_matches(source, model, path);
      return source;
    }
    bvh = mocap_io::motion_bvh(source, path);
  }
  std::string tried;
  const std::optional<mocap_io::JointMap> map =
      mocap_io::first_fitting_builtin_map(bvh, path, &tried);
  if (!map) throw sim::InvalidArgument(path + ": no built-in joint map fits its skeleton:" + tried);
  mocap_io::RetargetOptions options;
  options.source = path;
  return mocap_io::retarget_bvh(bvh, *map, target.spec, options).motion;
}

/// The joint groups' peak torque ratios, saturation, work and power from ID on `m`.
void joint_figures(const mjModel& m, const models::Rig& rig, BodyEvaluation* e,
                   const mocap_io::InverseDynamicsResult& id) {
  const int frames = static_cast<int>(id.times_s.size());
  const double dt = frames > 1 ? id.times_s[1] - id.times_s[0] : 0.0;
  e->power_W = id.generalized_force.cwiseProduct(id.qvel);
  std::vector<double> tau_max_of_dof = sim::motor_limits_per_dof(m);
  for (double& t : tau_max_of_dof) t = t > 0 ? t : 1e300;  // no motor: never saturates
  double first = -1;
  for (const models::JointGroup& g : rig.groups()) {
    JointEvaluation j;
    j.joint = g.name;
    j.tau_max_Nm = 1e300;
    for (int k = 0; k < g.dof_count; ++k) {
      const int v = g.dof_begin + k;
      const double tau_max = tau_max_of_dof[static_cast<size_t>(v)];
      j.tau_max_Nm = std::min(j.tau_max_Nm, tau_max);
      int run = 0;  // frames in a row above tau_max
      for (int f = 0; f < frames; ++f) {
        const double r = std::abs(id.generalized_force(f, v)) / tau_max;
        j.peak_ratio = std::max(j.peak_ratio, r);
        run = r > 1.0 ? run + 1 : 0;
        const int first_frame = f - run + 1;
        if (run > 0 && run * dt >= kSustained_s - 1e-9 &&
            (j.first_saturation_s < 0 ||
             id.times_s[static_cast<size_t>(first_frame)] < j.first_saturation_s))
          j.first_saturation_s = id.times_s[static_cast<size_t>(first_frame)];
      }
    }
    for (int f = 0; f < frames; ++f) {
      const double torque = id.generalized_force.row(f).segment(g.dof_begin, g.dof_count).norm();
      const double power = e->power_W.row(f).segment(g.dof_begin, g.dof_count).sum();
      j.peak_torque_Nm = std::max(j.peak_torque_Nm, torque);
      j.peak_power_W = std::max(j.peak_power_W, std::abs(power));
      (power > 0 ? j.positive_work_J : j.negative_work_J) += power * dt;
    }
    // The toes are reported but not judged (rig.h).
    const bool judged = models::strength_judged(g);
    if (judged && j.first_saturation_s >= 0 && (first < 0 || j.first_saturation_s < first)) {
      first = j.first_saturation_s;
      e->first_saturating_joint = j.joint;
    }
    e->joints.push_back(j);
  }
}

/// Static optimisation of the ID on the muscled model `m` of `c`.
void muscle_figures(const mjModel& m, const models::Character& c,
                    const mocap_io::InverseDynamicsResult& id, BodyEvaluation* e) {
  muscles::StaticOptimization so(
      muscles::MuscleSet(m, muscles::muscle_params(c.muscles, muscles::TendonChoice::kAllRigid)));
  const muscles::StaticOptimizationResult r =
      muscles::static_optimization(m, &so, id.qpos, id.qvel, id.generalized_force);
  for (int i = 0; i < so.set().size(); ++i) {
    e->muscles.push_back(so.set().params(i).name);
    e->muscle_peak_activation.push_back(r.activation.col(i).maxCoeff());
  }
  for (Eigen::Index k = 0; k < r.tau_Nm.cols(); ++k) {
    const double tau = r.tau_Nm.col(k).cwiseAbs().maxCoeff();
    if (tau > 1.0)
      e->reserve_share =
          std::max(e->reserve_share, r.reserve_Nm.col(k).cwiseAbs().maxCoeff() / tau);
  }
}

/// One body, whole: throws on bad input (caught by the caller, reported per body).
void evaluate_body(const std::string& motion_path, const models::CharacterSpec& reference,
                   const EvaluateOptions& o, const std::string& work_dir, BodyEvaluation* e) {
  const auto start = std::chrono::steady_clock::now();
  const models::Character c = body_character(e->body, reference);
  const sim::Model model = sim::Model::from_string(models::to_mjcf(c), e->body.name);
  const mjModel& m = *model;
  const models::Rig rig(m);
  e->weight_N = c.total_mass_kg() * 9.81;
  const mocap_io::Motion motion = motion_on_body(motion_path, c, m);
  mocap_io::InverseDynamicsOptions idopt;
  idopt.ground = mocap_io::GroundForces::kEstimated;
  const mocap_io::InverseDynamicsResult id = mocap_io::inverse_dynamics(m, motion, idopt);
  e->times_s = id.times_s;
  e->dof_names = id.dof_names;
  e->torque_Nm = id.generalized_force;
  e->grf_N.resize(id.generalized_force.rows(), 6);
  e->grf_N << id.ground_estimate.force_N[0], id.ground_estimate.force_N[1];
  e->grf_peak_bw = id.ground_force_N.col(2).maxCoeff() / e->weight_N;
  const Eigen::VectorXd fn = id.residual_force_N.rowwise().norm();
  const Eigen::VectorXd mn = id.residual_moment_Nm.rowwise().norm();
  e->residual_force_peak_N = fn.maxCoeff();
  e->residual_force_rms_N = std::sqrt(fn.squaredNorm() / static_cast<double>(fn.size()));
  e->residual_moment_peak_Nm = mn.maxCoeff();
  e->residual_moment_rms_Nm = std::sqrt(mn.squaredNorm() / static_cast<double>(mn.size()));
  joint_figures(m, rig, e, id);
  muscle_figures(m, c, id, e);
  if (o.tracking) {
    const std::string dir = work_dir + "/" + e->body.name;
    std::filesystem::create_directories(dir);
    mocap_io::Motion with_body = motion;
    mocap_io::set_motion_body(&with_body, c.spec);
    sim::write_file_atomically(dir + "/motion.csv", mocap_io::format_motion_csv(with_body));
    ScenarioConfig config;
    config.scenario = "mocap";
    config.character = c.spec;  // with the profile's masses and the tau_max factor
    config.character.muscles = false;
    config.motion_path = dir + "/motion.csv";
    config.track = true;
    config.tracker.lookahead_s = o.tracking_lookahead_s;
    const SamconParams& sp = o.samcon;  // its threads: the cores left over per body
    const SamconResult t = run_samcon(config, {}, sp);
    e->tracked = true;
    const double length = t.windows * sp.window_s;
    e->kept_up = t.windows_kept_up == t.windows && (t.fell_at_s < 0 || t.fell_at_s > length);
    e->fell_at_s = t.fell_at_s;
    e->joint_rms_deg = t.joint_rms_rad * 180.0 / M_PI;
    e->root_max_m = t.root_max_m;
    e->tracking_wall_s = t.wall_s;
    e->tracking_realtime_factor = t.wall_s > 0 ? length / t.wall_s : 0;
    e->peak_torque_ratio_tracked = t.peak_torque_ratio;
    e->joint_load_tracked = t.joint_load;
    for (std::size_t s = 0; s < 2; ++s)
      e->start_swing_lift_deg[s] = t.start_swing_lift_rad[s] * 180.0 / M_PI;
  }
  e->wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

void judge(BodyEvaluation* e) {
  const bool saturates = !e->first_saturating_joint.empty();
  // A tracking that keeps up only by leaning on a joint's range stop beyond the joint's strength
  // is not a way this body can do the motion.
  const bool overloaded =
      e->tracked && e->kept_up && e->joint_load_tracked.over_longest_s >= kSustained_s - 1e-9;
  e->feasible = !saturates && (!e->tracked || e->kept_up) && !overloaded;
  std::string v = e->feasible ? "can do it" : "cannot do it";
  if (saturates) v += ": " + e->first_saturating_joint + " exceeds tau_max first";
  if (e->tracked && !e->kept_up) {
    v += std::string(saturates ? "; " : ": ") + "the tracking falls at " +
         std::to_string(e->fell_at_s) + " s";
  }
  if (overloaded) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(2) << (saturates ? "; " : ": ")
      << "the tracking keeps up only with its joints over tau_max (motor + joint stop) for "
      << e->joint_load_tracked.over_longest_s << " s (last "
      << e->joint_load_tracked.over_longest_dof << ")";
    v += s.str();
  }
  e->verdict = v;
}

std::vector<EvaluationBody> parse_bodies(const std::string& json_text, const std::string& source) {
  json j;
  try {
    j = json::parse(json_text);
  } catch (const json::exception& ex) {
    throw sim::InvalidArgument(source + ": not JSON: " + ex.what());
  }
  if (!j.is_object() || !j.contains("bodies") || !j["bodies"].is_array() || j["bodies"].empty()) {
    throw sim::InvalidArgument(source +
                               ": expected {\"bodies\": [ {...}, ... ]} with at least one body");
  }
  std::vector<EvaluationBody> out;
  int index = 0;
  for (const json& b : j["bodies"]) {
    ++index;
    const std::string where = source + ": body " + std::to_string(index);
    if (!b.is_object()) throw sim::InvalidArgument(where + ": must be an object");
    const auto number = [&](const char* field, double fallback) {
      if (!b.contains(field)) return fallback;
      if (!b[field].is_number())
        throw sim::InvalidArgument(where + ": " + field + " must be a number");
      return b[field].get<double>();
    };
    const auto text = [&](const char* field, const std::string& fallback) {
      if (!b.contains(field)) return fallback;
      if (!b[field].is_string())
        throw sim::InvalidArgument(where + ": " + field + " must be a string");
      return b[field].get<std::string>();
    };
    EvaluationBody body;
    body.spec.height_m = number("height_m", 1.8);
    body.spec.mass_kg = number("mass_kg", 80);
    const std::string sex = text("sex", "male");
    if (sex != "male" && sex != "female")
      throw sim::InvalidArgument(where + ": sex must be male or female, got '" + sex + "'");
    body.spec.sex = sex == "male" ? models::Sex::kMale : models::Sex::kFemale;
    body.profile = text("profile", "standard");
    if (body.profile != "standard" && body.profile != "heavy_trunk_thighs") {
      throw sim::InvalidArgument(where + ": profile must be standard or heavy_trunk_thighs, got '" +
                                 body.profile + "'");
    }
    const std::string tau = text("tau_max", "scaled");
    if (tau != "scaled" && tau != "fixed")
      throw sim::InvalidArgument(where + ": tau_max must be scaled or fixed, got '" + tau + "'");
    body.tau_rule = tau == "fixed" ? TauMaxRule::kFixed : TauMaxRule::kScaled;
    body.name = text("name", "body" + std::to_string(index));
    if (body.name.empty() || body.name.find_first_of("/\\ ") != std::string::npos)
      throw sim::InvalidArgument(where + ": name must be non-empty, without spaces or slashes");
    for (const EvaluationBody& other : out)
      if (other.name == body.name)
        throw sim::InvalidArgument(where + ": name '" + body.name + "' twice");
    try {
      models::generate_character(body.spec);  // validates height, mass
    } catch (const sim::InvalidArgument& ex) {
      throw sim::InvalidArgument(where + " ('" + body.name + "'): " + ex.what());
    }
    out.push_back(body);
  }
  return out;
}

std::vector<BodyEvaluation> evaluate_motion(const std::string& motion_path,
                                            const std::vector<EvaluationBody>& bodies,
                                            const EvaluateOptions& options,
                                            const std::string& work_dir,
                                            const std::function<void(int, int)>& progress) {
  // The reference body (the motion's own; the fixed tau_max rule's): a CSV's header, else the
  // default character.
  models::CharacterSpec reference;
  const std::string ext = std::filesystem::path(motion_path).extension().string();
  if (ext != ".bvh" && ext != ".BVH") {
    const mocap_io::Motion m = mocap_io::read_motion_csv(motion_path);
    if (const auto body = mocap_io::motion_body(m, motion_path)) reference = *body;
  }
  reference.muscles = false;
  std::vector<BodyEvaluation> out(bodies.size());
  for (size_t i = 0; i < bodies.size(); ++i) out[i].body = bodies[i];
  const int threads = options.threads > 0
                          ? options.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  // Bodies in parallel; each body's tracking search gets the cores left over (any split gives
  // the same results).
  const int body_threads = std::min<int>(threads, static_cast<int>(out.size()));
  EvaluateOptions per_body = options;
  per_body.samcon.threads = std::max(1, threads / std::max(1, body_threads));
  std::atomic<int> next{0};
  int done = 0;
  std::mutex progress_mutex;
  auto work = [&]() {
    for (int i = next++; i < static_cast<int>(out.size()); i = next++) {
      BodyEvaluation& e = out[static_cast<size_t>(i)];
      try {
        evaluate_body(motion_path, reference, per_body, work_dir, &e);
        judge(&e);
      } catch (const std::exception& ex) {
        e.error = ex.what();
        e.verdict = "not evaluated: " + e.error;
      }
      const std::lock_guard<std::mutex> lock(progress_mutex);
      ++done;
      if (progress) progress(done, static_cast<int>(out.size()));
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < body_threads; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  return out;
}

}  // namespace biodyn::scenarios
