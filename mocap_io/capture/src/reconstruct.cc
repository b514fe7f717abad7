// Multi-view reconstruction of unlabelled markers (reconstruct.h).
#include "biodyn/capture/reconstruct.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <string>

#include "biodyn/sim/errors.h"

namespace biodyn::capture {
namespace {

constexpr int kGaussNewtonIterations = 3;

Eigen::Matrix3d skew(const Eigen::Vector3d& t) {
  Eigen::Matrix3d s;
  s << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  return s;
}

// Distance of normalised point x from the line l (a x + b y + c = 0), normalised units.
double line_distance(const Eigen::Vector3d& l, const Eigen::Vector2d& x) {
  const double n = std::hypot(l.x(), l.y());
  return n > 0 ? std::abs(l.x() * x.x() + l.y() * x.y() + l.z()) / n : 0.0;
}

}  // namespace

void ReconstructionParams::validate() const {
  const auto bad = [](const char* field, double v) {
    throw sim::InvalidArgument(std::string("reconstruction: ") + field + ": out of range, got " +
                               std::to_string(v));
  };
  if (!(epipolar_gate_px > 0) || epipolar_gate_px > 100)
    bad("epipolar_gate_px (0, 100]", epipolar_gate_px);
  if (!(support_gate_px > 0) || support_gate_px > 100)
    bad("support_gate_px (0, 100]", support_gate_px);
  if (min_views < 2) bad("min_views >= 2", min_views);
  if (!(max_residual_px > 0)) bad("max_residual_px > 0", max_residual_px);
  for (int k = 0; k < 3; ++k) {
    if (!(volume_max_W[k] > volume_min_W[k])) bad("volume_max_W > volume_min_W", volume_max_W[k]);
  }
}

Reconstructor::Reconstructor(const Rig& rig, const ReconstructionParams& params)
    : rig_(rig), params_(params) {
  params_.validate();
  const int n = rig_.size();
  if (n < 2)
    throw sim::InvalidArgument("reconstruction: a rig needs at least 2 cameras, got " +
                               std::to_string(n));
  essential_.resize(static_cast<std::size_t>(n * n));
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const Camera& a = rig_.cameras[i];
      const Camera& b = rig_.cameras[j];
      const Eigen::Matrix3d R = b.R_CW * a.R_CW.transpose();
      const Eigen::Vector3d t = b.R_CW * (a.p_WC - b.p_WC);
      essential_[i * n + j] = skew(t) * R;
    }
  }
  normalised_.resize(n);
  used_.resize(n);
}

bool triangulate_normalised(const Rig& rig,
                            const std::vector<std::pair<int, Eigen::Vector2d>>& views,
                            Eigen::Vector3d* p_W, double* residual_px) {
  if (views.size() < 2) return false;
  // Linear first (each view: x (r3 . (X - C)) = r1 . (X - C), same for y), then Gauss-Newton on
  // the reprojection error in pixels.
  Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
  Eigen::Vector3d Atb = Eigen::Vector3d::Zero();
  for (const auto& [c, x] : views) {
    const Camera& cam = rig.cameras[c];
    for (int k = 0; k < 2; ++k) {
      const Eigen::Vector3d row = x[k] * cam.R_CW.row(2).transpose() - cam.R_CW.row(k).transpose();
      AtA += row * row.transpose();
      Atb += row * row.dot(cam.p_WC);
    }
  }
  Eigen::Vector3d X = AtA.ldlt().solve(Atb);
  for (int it = 0; it < kGaussNewtonIterations; ++it) {
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (const auto& [c, x] : views) {
      const Camera& cam = rig.cameras[c];
      const Eigen::Vector3d q = cam.R_CW * (X - cam.p_WC);
      if (q.z() <= 0) return false;
      const double f = cam.K.fx_px;
      const Eigen::Vector2d r = f * (q.head<2>() / q.z() - x);
      Eigen::Matrix<double, 2, 3> J;
      J.row(0) = f / q.z() * (cam.R_CW.row(0) - q.x() / q.z() * cam.R_CW.row(2));
      J.row(1) = f / q.z() * (cam.R_CW.row(1) - q.y() / q.z() * cam.R_CW.row(2));
      H += J.transpose() * J;
      g += J.transpose() * r;
    }
    X -= H.ldlt().solve(g);
  }
  double sum2 = 0;
  for (const auto& [c, x] : views) {
    const Camera& cam = rig.cameras[c];
    const Eigen::Vector3d q = cam.R_CW * (X - cam.p_WC);
    if (q.z() <= 0) return false;
    sum2 += (cam.K.fx_px * (q.head<2>() / q.z() - x)).squaredNorm();
  }
  *p_W = X;
  *residual_px = std::sqrt(sum2 / static_cast<double>(views.size()));
  return true;
}

bool Reconstructor::triangulate(const std::vector<std::pair<int, int>>& views, Eigen::Vector3d* p_W,
                                double* residual_px) const {
  scratch_.clear();
  for (const auto& [c, b] : views) scratch_.emplace_back(c, normalised_[c][b]);
  return triangulate_normalised(rig_, scratch_, p_W, residual_px);
}

void Reconstructor::gather_support(Candidate* c) const {
  for (int k = 0; k < rig_.size(); ++k) {
    if (std::any_of(c->views.begin(), c->views.end(), [k](auto& v) { return v.first == k; }))
      continue;
    const Camera& cam = rig_.cameras[k];
    const Eigen::Vector3d q = cam.R_CW * (c->p_W - cam.p_WC);
    if (q.z() <= 0) continue;
    const Eigen::Vector2d x = q.head<2>() / q.z();
    int best = -1;
    double best_px = params_.support_gate_px;
    for (int b = 0; b < static_cast<int>(normalised_[k].size()); ++b) {
      if (used_[k][b]) continue;
      const double px = cam.K.fx_px * (normalised_[k][b] - x).norm();
      if (px < best_px) {
        best_px = px;
        best = b;
      }
    }
    if (best >= 0) c->views.emplace_back(k, best);
  }
}

bool Reconstructor::refine(Candidate* c) const {
  while (true) {
    if (static_cast<int>(c->views.size()) < params_.min_views) return false;
    if (!triangulate(c->views, &c->p_W, &c->residual_px)) return false;
    // The worst view's error.
    int worst = -1;
    double worst_px = 0;
    for (int v = 0; v < static_cast<int>(c->views.size()); ++v) {
      const auto [k, b] = c->views[v];
      const Camera& cam = rig_.cameras[k];
      const Eigen::Vector3d q = cam.R_CW * (c->p_W - cam.p_WC);
      const double px = cam.K.fx_px * (q.head<2>() / q.z() - normalised_[k][b]).norm();
      if (px > worst_px) {
        worst_px = px;
        worst = v;
      }
    }
    if (worst_px <= params_.max_residual_px) break;
    if (static_cast<int>(c->views.size()) <= params_.min_views) return false;
    c->views.erase(c->views.begin() + worst);
  }
  return (c->p_W.array() >= params_.volume_min_W.array()).all() &&
         (c->p_W.array() <= params_.volume_max_W.array()).all();
}

bool Reconstructor::epipolar_match(std::pair<int, int> u, std::pair<int, int> v) const {
  if (u.first > v.first) std::swap(u, v);
  const auto [i, a] = u;
  const auto [j, b] = v;
  const Eigen::Matrix3d& E = essential_[static_cast<std::size_t>(i * rig_.size() + j)];
  const Eigen::Vector3d line_j = E * normalised_[i][a].homogeneous();
  const Eigen::Vector3d line_i = E.transpose() * normalised_[j][b].homogeneous();
  return rig_.cameras[j].K.fx_px * line_distance(line_j, normalised_[j][b]) <=
             params_.epipolar_gate_px &&
         rig_.cameras[i].K.fx_px * line_distance(line_i, normalised_[i][a]) <=
             params_.epipolar_gate_px;
}

void Reconstructor::accept(const Candidate& c, std::vector<Point3>* points) {
  for (const auto& [k, b] : c.views) used_[k][b] = 1;
  Point3 p;
  p.p_W = c.p_W;
  p.views = c.views;
  std::sort(p.views.begin(), p.views.end());
  p.residual_px = c.residual_px;
  points->push_back(std::move(p));
}

void Reconstructor::continue_tracked(const std::vector<std::vector<int>>& tracks) {
  for (std::size_t i = 0; i < last_tracks_.size(); ++i) {
    Candidate c;
    for (const auto& [k, id] : last_tracks_[i]) {
      const std::vector<int>& ids = tracks[static_cast<std::size_t>(k)];
      const auto at = std::find(ids.begin(), ids.end(), id);
      if (at != ids.end()) c.views.emplace_back(k, static_cast<int>(at - ids.begin()));
    }
    if (c.views.size() < 2 || !triangulate(c.views, &c.p_W, &c.residual_px)) continue;
    gather_support(&c);
    c.continues = static_cast<int>(i);
    if (refine(&c) && continuation_holds(c)) candidates_.push_back(std::move(c));
  }
}

bool Reconstructor::continuation_holds(const Candidate& c) const {
  if ((c.p_W - last_points_[static_cast<std::size_t>(c.continues)]).norm() > kMaxContinuedStep_m)
    return false;
  // Two views: they must pass the epipolar gate a new pair passes.
  return c.views.size() > 2 || epipolar_match(c.views[0], c.views[1]);
}

void Reconstructor::remember_tracks(const std::vector<std::vector<int>>* tracks,
                                    const std::vector<Point3>& points) {
  last_points_.clear();
  last_tracks_.clear();
  if (!tracks) return;
  for (const Point3& p : points) {
    last_points_.push_back(p.p_W);
    last_tracks_.emplace_back();
    for (const auto& [k, b] : p.views)
      last_tracks_.back().emplace_back(
          k, (*tracks)[static_cast<std::size_t>(k)][static_cast<std::size_t>(b)]);
  }
}

void Reconstructor::reconstruct(const std::vector<std::vector<Blob>>& blobs,
                                std::vector<Point3>* points,
                                const std::vector<std::vector<int>>* tracks) {
  const int n = rig_.size();
  if (static_cast<int>(blobs.size()) != n)
    throw sim::InvalidArgument("reconstruction: " + std::to_string(blobs.size()) +
                               " blob lists for a rig of " + std::to_string(n) + " cameras");
  if (tracks) {
    bool match = static_cast<int>(tracks->size()) == n;
    for (int c = 0; match && c < n; ++c) match = (*tracks)[c].size() == blobs[c].size();
    if (!match)
      throw sim::InvalidArgument("reconstruction: the 2D track ids do not match the blob lists");
  }
  for (int c = 0; c < n; ++c) {
    normalised_[c].resize(blobs[c].size());
    for (std::size_t b = 0; b < blobs[c].size(); ++b)
      normalised_[c][b] = rig_.cameras[c].undistort(blobs[c][b].uv_px);
    used_[c].assign(blobs[c].size(), 0);
  }
  points->clear();
  continued_ = 0;
  candidates_.clear();
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      for (int a = 0; a < static_cast<int>(normalised_[i].size()); ++a) {
        for (int b = 0; b < static_cast<int>(normalised_[j].size()); ++b) {
          if (!epipolar_match({i, a}, {j, b})) continue;
          Candidate c;
          c.views = {{i, a}, {j, b}};
          if (!triangulate(c.views, &c.p_W, &c.residual_px)) continue;
          gather_support(&c);
          if (refine(&c)) candidates_.push_back(std::move(c));
        }
      }
    }
  }
  if (tracks) continue_tracked(*tracks);
  // Last frame's points continued along their 2D tracks first (a pair of blobs that happens to
  // meet on an epipolar line, with a third camera's stray blob near it, does not take their
  // blobs), then most views, then the smallest error; ties by the first view (deterministic).
  std::sort(candidates_.begin(), candidates_.end(), [](const Candidate& x, const Candidate& y) {
    if ((x.continues >= 0) != (y.continues >= 0)) return x.continues >= 0;
    if (x.views.size() != y.views.size()) return x.views.size() > y.views.size();
    if (x.residual_px != y.residual_px) return x.residual_px < y.residual_px;
    return x.views < y.views;
  });
  for (Candidate& c : candidates_) {
    const auto taken = [&](const std::pair<int, int>& v) { return used_[v.first][v.second] != 0; };
    if (std::any_of(c.views.begin(), c.views.end(), taken)) {
      c.views.erase(std::remove_if(c.views.begin(), c.views.end(), taken), c.views.end());
      // A continued point that lost blobs to an earlier one is checked again as it was built.
      if (!refine(&c) || (c.continues >= 0 && !continuation_holds(c))) continue;
    }
    accept(c, points);
    continued_ += c.continues >= 0 ? 1 : 0;
  }
  remember_tracks(tracks, *points);
}

}  // namespace biodyn::capture
