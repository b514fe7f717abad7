// Retargeting (retarget_internal.h): contact detection on tracked points, and the feet: their
// sole points, where the contacts pin them, and how the pins fade in and out around a stance.
#include <algorithm>
#include <cmath>
#include <limits>

#include "retarget_internal.h"

namespace biodyn::mocap_io::retarget_internal {
namespace {

/// m^2: planted sole points spread less than this (about 2 cm RMS from their mean) do not fix
/// the foot's yaw; it is held from the previous frame.
constexpr double kMinYawSpread_m2 = 0.02 * 0.02;

/// The correction fitted to the foot's points planted at `plant_at` on frame f: translation
/// from their means, yaw (about the ankle) when they are spread out, else `held`'s. `n`
/// receives how many are planted (none: no correction).
FootCorrection fit_correction(const FootTrack& t, int f, const SolePoints& plant_at,
                              const std::array<bool, kSoles>& is_planted,
                              const FootCorrection& held, int* n) {
  const SolePoints& F = t.free[at(f)];
  const Vector3d& a = t.ankle[at(f)];
  Vector3d mu = Vector3d::Zero(), mv = Vector3d::Zero();
  *n = 0;
  for (int p = 0; p < kSoles; ++p) {
    if (!is_planted[at(p)]) continue;
    mu += F[at(p)] - a;
    mv += plant_at[at(p)] - a;
    ++*n;
  }
  if (*n == 0) return FootCorrection{};
  mu /= *n;
  mv /= *n;
  double cross = 0.0, dot = 0.0, spread = 0.0;
  for (int p = 0; p < kSoles; ++p) {
    if (!is_planted[at(p)]) continue;
    const Vector3d u = F[at(p)] - a - mu, v = plant_at[at(p)] - a - mv;
    cross += u.x() * v.y() - u.y() * v.x();
    dot += u.x() * v.x() + u.y() * v.y();
    spread += u.x() * u.x() + u.y() * u.y();
  }
  FootCorrection c;
  c.yaw = spread > kMinYawSpread_m2 * *n ? std::atan2(cross, dot) : held.yaw;
  c.t = mv - rot_z(c.yaw) * mu;
  return c;
}

/// Pass 1: plants, and the correction fitted to them, frame by frame. A point touching down
/// while others are planted lands where the corrected foot puts it (so the planted points keep
/// the foot's shape); from the air, where it is.
void plant_contacts(FootTrack* t) {
  const int frames = t->frames();
  std::array<std::vector<bool>, kSoles> on;
  for (int p = 0; p < kSoles; ++p) on[at(p)] = flags(t->contacts[at(p)], frames);
  SolePoints plant_at;
  plant_at.fill(Vector3d::Zero());
  std::array<bool, kSoles> is_planted{};
  for (int f = 0; f < frames; ++f) {
    const SolePoints& F = t->free[at(f)];
    const FootCorrection held =
        f > 0 && t->stance[at(f - 1)] ? t->correction[at(f - 1)] : FootCorrection{};
    int n = 0;
    const FootCorrection before = fit_correction(*t, f, plant_at, is_planted, held, &n);
    for (int p = 0; p < kSoles; ++p) {
      if (!on[at(p)][at(f)] || is_planted[at(p)]) continue;
      plant_at[at(p)] = n > 0 ? before.apply(F[at(p)], t->ankle[at(f)]) : F[at(p)];
      plant_at[at(p)].z() = 0.0;  // the sole on the floor
      is_planted[at(p)] = true;
    }
    t->correction[at(f)] = fit_correction(*t, f, plant_at, is_planted, held, &n);
    t->stance[at(f)] = n > 0;
    for (int p = 0; p < kSoles; ++p) {
      if (!is_planted[at(p)]) continue;
      t->planted[at(f)][at(p)] = true;
      t->plant[at(f)][at(p)] = plant_at[at(p)];
      if (f + 1 >= frames || !on[at(p)][at(f + 1)]) is_planted[at(p)] = false;
    }
  }
}

/// Off the stance: the correction fades out after lift-off and in before touch-down, over at
/// most `blend` frames (half the swing when it is shorter); the roll is free in mid-swing.
void fade_correction(FootTrack* t, int blend) {
  const int frames = t->frames();
  const std::vector<FootCorrection> c = t->correction;
  t->roll_weight.assign(at(frames), 0.0);
  for (int f = 0; f < frames;) {
    if (t->stance[at(f)]) {
      ++f;
      continue;
    }
    const int a = f;
    while (f < frames && !t->stance[at(f)]) ++f;
    const int b = f - 1;  // swing [a, b]
    const double len = std::max(1.0, std::min<double>(blend, (b - a + 2) / 2));
    for (int g = a; g <= b; ++g) {
      FootCorrection v;
      double w_out = 0.0, w_in = 0.0;
      if (a > 0) {
        w_out = 1.0 - smoothstep((g - (a - 1)) / len);
        v = v.plus(c[at(a - 1)].scaled(w_out));
      }
      if (b + 1 < frames) {
        w_in = 1.0 - smoothstep(((b + 1) - g) / len);
        v = v.plus(c[at(b + 1)].scaled(w_in));
      }
      t->correction[at(g)] = v;
      t->roll_weight[at(g)] = 1.0 - std::max(w_out, w_in);
    }
  }
}

/// Each point's share of the contact weight: 1 in contact, faded over `blend` frames before it
/// and after it (over one frame after a released contact).
void share_contact_weight(FootTrack* t, int blend) {
  const int frames = t->frames();
  t->contact_share.assign(at(frames), std::array<double, kSoles>{});
  for (int p = 0; p < kSoles; ++p) {
    const std::vector<Interval>& ints = t->contacts[at(p)];
    t->released[at(p)].resize(ints.size(), false);
    for (size_t k = 0; k < ints.size(); ++k) {
      const int fade_out = t->released[at(p)][k] ? 1 : blend;
      for (int g = std::max(0, ints[k].first - blend);
           g <= std::min(frames - 1, ints[k].second + fade_out); ++g) {
        double share = 1.0;
        if (g < ints[k].first) share = smoothstep(1.0 - (ints[k].first - g) / (blend + 1.0));
        if (g > ints[k].second) share = smoothstep(1.0 - (g - ints[k].second) / (fade_out + 1.0));
        t->contact_share[at(g)][at(p)] = std::max(t->contact_share[at(g)][at(p)], share);
      }
    }
  }
}

/// Pass 2: each point's mismatch between its plant and the corrected foot, faded in over
/// `blend` frames before its touch-down and out after its lift-off, so it does not jump.
void fade_point_mismatch(FootTrack* t, int blend) {
  const int frames = t->frames();
  t->extra.assign(at(frames), SolePoints{});
  for (SolePoints& e : t->extra) e.fill(Vector3d::Zero());
  for (int p = 0; p < kSoles; ++p) {
    const std::vector<Interval>& ints = t->contacts[at(p)];
    const auto corrected = [&](int f) {
      return t->correction[at(f)].apply(t->free[at(f)][at(p)], t->ankle[at(f)]);
    };
    for (size_t k = 0; k < ints.size(); ++k) {
      const int t0 = ints[k].first, t1 = ints[k].second;
      const Vector3d pl = t->plant[at(t0)][at(p)];
      const int prev_end = k > 0 ? ints[k - 1].second : -1;
      const int next_start = k + 1 < ints.size() ? ints[k + 1].first : frames;
      if (t0 > 0) {
        const Vector3d m0 = pl - corrected(t0);
        const int len = std::max(1, std::min(blend, t0 - prev_end - 1));
        for (int g = std::max(prev_end + 1, t0 - len); g < t0; ++g) {
          t->extra[at(g)][at(p)] += m0 * smoothstep(static_cast<double>(g - (t0 - 1 - len)) / len);
        }
      }
      if (t1 + 1 < frames) {
        const Vector3d m1 = pl - corrected(t1 + 1);
        const int len = std::max(1, std::min(blend, next_start - t1 - 1));
        for (int g = t1 + 1; g <= std::min(t1 + len, next_start - 1); ++g) {
          t->extra[at(g)][at(p)] += m1 * (1.0 - smoothstep(static_cast<double>(g - t1 - 1) / len));
        }
      }
    }
  }
}

}  // namespace

// ----------------------------------------------------------------------------------------------
// Contact detection
// ----------------------------------------------------------------------------------------------

std::vector<Interval> detect_point(const std::vector<Vector3d>& p, double dt,
                                   const ContactOptions& o, double* level) {
  const int n = static_cast<int>(p.size());
  const int w = std::max(1, static_cast<int>(std::lround(o.speed_window_s / dt)));
  std::vector<double> speed(p.size());
  for (int f = 0; f < n; ++f) {
    const int a = std::max(0, f - w), b = std::min(n - 1, f + w);
    const Vector3d d = p[at(b)] - p[at(a)];
    speed[at(f)] = b > a ? std::hypot(d.x(), d.y()) / ((b - a) * dt) : 0.0;
  }
  std::vector<double> slow_z;
  for (int f = 0; f < n; ++f) {
    if (speed[at(f)] < o.enter_speed_m_s) slow_z.push_back(p[at(f)].z());
  }
  if (slow_z.empty()) {  // never still: the lowest height is the level
    double lo = std::numeric_limits<double>::infinity();
    for (const Vector3d& q : p) lo = std::min(lo, q.z());
    slow_z.push_back(lo);
  }
  *level = median(slow_z);

  std::vector<Interval> raw;
  bool in = false;
  for (int f = 0; f < n; ++f) {
    const double h = p[at(f)].z() - *level;
    const double v = speed[at(f)];
    if (!in && h < o.enter_height_m && v < o.enter_speed_m_s) {
      in = true;
      raw.push_back({f, f});
    } else if (in && (h > o.exit_height_m || v > o.exit_speed_m_s)) {
      in = false;
    }
    if (in) raw.back().second = f;
  }
  const int min_frames = std::max(1, static_cast<int>(std::lround(o.min_duration_s / dt)));
  std::vector<Interval> bridged;
  for (const Interval& i : raw) {
    if (!bridged.empty() && i.first - bridged.back().second - 1 < min_frames) {
      bridged.back().second = i.second;
    } else {
      bridged.push_back(i);
    }
  }
  std::vector<Interval> out;
  for (const Interval& i : bridged) {
    if (i.second - i.first + 1 >= min_frames) out.push_back(i);
  }
  return out;
}

std::vector<bool> flags(const std::vector<Interval>& intervals, int frames) {
  std::vector<bool> out(at(frames), false);
  for (const Interval& i : intervals) {
    for (int f = i.first; f <= i.second; ++f) out[at(f)] = true;
  }
  return out;
}

// ----------------------------------------------------------------------------------------------
// Feet
// ----------------------------------------------------------------------------------------------

Sole sole_of(const models::Character& c, const std::string& side) {
  const models::Geom& fb = c.find("foot_" + side)->geoms.front();
  const models::Geom& tb = c.find("toes_" + side)->geoms.front();
  const double lateral = side == "l" ? 1.0 : -1.0;  // +y is the left side
  const double heel_x = fb.center_B.x() - fb.half_extents.x();
  const double foot_sole = fb.center_B.z() - fb.half_extents.z();
  const double ball_x = tb.center_B.x() - tb.half_extents.x();
  const double tip_x = tb.center_B.x() + tb.half_extents.x();
  const double toes_sole = tb.center_B.z() - tb.half_extents.z();
  Sole s;
  s.point_B[0] = Vector3d(heel_x, fb.center_B.y() - lateral * fb.half_extents.y(), foot_sole);
  s.point_B[1] = Vector3d(heel_x, fb.center_B.y() + lateral * fb.half_extents.y(), foot_sole);
  s.point_B[2] = Vector3d(ball_x, tb.center_B.y() - lateral * tb.half_extents.y(), toes_sole);
  s.point_B[3] = Vector3d(ball_x, tb.center_B.y() + lateral * tb.half_extents.y(), toes_sole);
  s.point_B[4] = Vector3d(tip_x, tb.center_B.y(), toes_sole);
  return s;
}

SolePoints FootTrack::free_points(int f, double roll) const {
  const Matrix3d r = r_free[at(f)] * rot_x(roll);
  const Matrix3d r_toes = r * rot_y(toe[at(f)]);
  const Vector3d a = ankle[at(f)];
  const Vector3d m = a + r * ankle_to_mtp_W;
  SolePoints out;
  for (int p = 0; p < kSoles; ++p) {
    out[at(p)] = Sole::on_toes(p) ? Vector3d(m + r_toes * sole.point_B[at(p)])
                                  : Vector3d(a + r * sole.point_B[at(p)]);
  }
  return out;
}

void FootTrack::compose(int f, double roll, SolePoints* sole_target, Vector3d* ankle_target) const {
  const SolePoints F = roll == 0.0 ? free[at(f)] : free_points(f, roll);
  const FootCorrection& c = correction[at(f)];
  double lowest = 0.0;
  for (int p = 0; p < kSoles; ++p) {
    if (planted[at(f)][at(p)]) {
      (*sole_target)[at(p)] = plant[at(f)][at(p)];
      continue;
    }
    (*sole_target)[at(p)] = c.apply(F[at(p)], ankle[at(f)]) + extra[at(f)][at(p)];
    lowest = std::min(lowest, (*sole_target)[at(p)].z());
  }
  for (int p = 0; p < kSoles; ++p) {
    if (!planted[at(f)][at(p)]) (*sole_target)[at(p)].z() -= lowest;
  }
  *ankle_target = ankle[at(f)] + c.t - Vector3d(0.0, 0.0, lowest);
}

void plan_contacts(const ContactOptions& o, double dt, int blend, FootTrack* t) {
  // A heel, a ball or the tip can touch alone (heel strike, heel-off, a pivot on the toes,
  // kneeling on tucked toes).
  for (int p = 0; p < kSoles; ++p) {
    std::vector<Vector3d> track(at(t->frames()));
    for (int f = 0; f < t->frames(); ++f) track[at(f)] = t->free[at(f)][at(p)];
    double level = 0.0;
    t->contacts[at(p)] = detect_point(track, dt, o, &level);
  }
  plant(t, blend);
}

void plant(FootTrack* t, int blend) {
  const int frames = t->frames();
  t->planted.assign(at(frames), std::array<bool, kSoles>{});
  t->plant.assign(at(frames), SolePoints{});
  t->correction.assign(at(frames), FootCorrection{});
  t->stance.assign(at(frames), false);
  plant_contacts(t);
  fade_correction(t, blend);
  share_contact_weight(t, blend);
  fade_point_mismatch(t, blend);
}

void release(FootTrack* t, int p, int f, int blend) {
  std::vector<Interval>& ints = t->contacts[at(p)];
  for (size_t k = 0; k < ints.size(); ++k) {
    if (ints[k].first > f || ints[k].second < f) continue;
    t->released[at(p)].resize(ints.size(), false);
    if (ints[k].first == f) {
      ints.erase(ints.begin() + static_cast<long>(k));
      t->released[at(p)].erase(t->released[at(p)].begin() + static_cast<long>(k));
    } else {
      ints[k].second = f - 1;
      t->released[at(p)][k] = true;
    }
    break;
  }
  plant(t, blend);
}

}  // namespace biodyn::mocap_io::retarget_internal
