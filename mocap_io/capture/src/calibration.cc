// Rig calibration from a wand and an L-frame (calibration.h).
#include "biodyn/capture/calibration.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "biodyn/sim/errors.h"

namespace biodyn::capture {
namespace {

// The middle blob must lie this close to the line through the ends: px, and a fraction of the
// ends' distance (lens distortion bends a long wand's image a little).
constexpr double kWandLineTolerance_px = 2.0;
constexpr double kWandLineTolerance = 0.03;
// The image ratio |AB| / |AC| may differ from the wand's by this much (perspective).
constexpr double kWandRatioTolerance = 0.12;
// m: an L-frame's points match its template's distances to this (each pair).
constexpr double kLFrameDistanceTolerance_m = 0.01;

[[noreturn]] void bad(const std::string& what) {
  throw sim::InvalidArgument("calibration: " + what);
}

// Per camera: rotation (angle-axis of R_CW) and translation t = -R_CW p_WC.
struct PoseParams {
  double aa[3];
  double t[3];
};

PoseParams to_params(const Camera& c) {
  PoseParams p;
  const Eigen::AngleAxisd aa(c.R_CW);
  const Eigen::Vector3d v = aa.angle() * aa.axis();
  const Eigen::Vector3d t = -c.R_CW * c.p_WC;
  for (int k = 0; k < 3; ++k) {
    p.aa[k] = v[k];
    p.t[k] = t[k];
  }
  return p;
}

void from_params(const PoseParams& p, Camera* c) {
  const Eigen::Vector3d v(p.aa[0], p.aa[1], p.aa[2]);
  const double angle = v.norm();
  c->R_CW = angle > 0 ? Eigen::AngleAxisd(angle, v / angle).toRotationMatrix()
                      : Eigen::Matrix3d::Identity();
  c->p_WC = -c->R_CW.transpose() * Eigen::Vector3d(p.t[0], p.t[1], p.t[2]);
}

// One wand marker in one image: the pixel it was seen at against the lens model.
struct WandResidual {
  WandResidual(const Eigen::Vector2d& uv, double offset) : uv_(uv), offset_(offset) {}
  template <typename T>
  bool operator()(const T* pose, const T* lens, const T* a, const T* d, T* r) const {
    const T p_W[3] = {a[0] + T(offset_) * d[0], a[1] + T(offset_) * d[1], a[2] + T(offset_) * d[2]};
    T p_C[3];
    ceres::AngleAxisRotatePoint(pose, p_W, p_C);
    for (int k = 0; k < 3; ++k) p_C[k] += pose[3 + k];
    T u, v;
    distort_to_pixels(lens, p_C[0] / p_C[2], p_C[1] / p_C[2], &u, &v);
    r[0] = u - T(uv_.x());
    r[1] = v - T(uv_.y());
    return true;
  }

 private:
  Eigen::Vector2d uv_;
  double offset_;
};

// Normalised image points of the wand per camera and frame with the current lenses.
using Normalised = std::vector<std::vector<std::array<Eigen::Vector2d, 3>>>;

Normalised normalise(const Rig& rig, const WandObservations& w) {
  Normalised n(w.cameras(), std::vector<std::array<Eigen::Vector2d, 3>>(w.frames()));
  for (int c = 0; c < w.cameras(); ++c) {
    for (int f = 0; f < w.frames(); ++f) {
      if (!w.seen[c][f]) continue;
      for (int m = 0; m < 3; ++m) n[c][f][m] = rig.cameras[c].undistort(w.abc_px[c][f][m]);
    }
  }
  return n;
}

// Wand markers triangulated from the registered cameras (frames seen by two of them).
std::vector<std::array<Eigen::Vector3d, 3>> triangulate_wand(const Rig& rig,
                                                             const WandObservations& w,
                                                             const Normalised& n,
                                                             const std::vector<char>& registered,
                                                             std::vector<char>* ok) {
  std::vector<std::array<Eigen::Vector3d, 3>> points(w.frames());
  ok->assign(w.frames(), 0);
  std::vector<std::pair<int, Eigen::Vector2d>> views;
  for (int f = 0; f < w.frames(); ++f) {
    bool all = true;
    for (int m = 0; m < 3 && all; ++m) {
      views.clear();
      for (int c = 0; c < w.cameras(); ++c) {
        if (registered[c] && w.seen[c][f]) views.emplace_back(c, n[c][f][m]);
      }
      double residual = 0;
      all = views.size() >= 2 && triangulate_normalised(rig, views, &points[f][m], &residual);
    }
    (*ok)[f] = all ? 1 : 0;
  }
  return points;
}

// The best-seen pair's relative pose from the essential matrix, the first camera at the
// origin, scaled by the wand's length.
std::pair<int, int> initial_pair(const WandObservations& w, const Normalised& n,
                                 const CalibrationParams& p, Rig* rig) {
  int best_i = -1, best_j = -1, best = 0;
  for (int i = 0; i < w.cameras(); ++i) {
    for (int j = i + 1; j < w.cameras(); ++j) {
      int shared = 0;
      for (int f = 0; f < w.frames(); ++f) shared += w.seen[i][f] && w.seen[j][f] ? 1 : 0;
      if (shared > best) {
        best = shared;
        best_i = i;
        best_j = j;
      }
    }
  }
  if (best < p.min_shared_views)
    bad("no two cameras saw the wand together in " + std::to_string(p.min_shared_views) +
        " frames (best: " + std::to_string(best) + ")");
  std::vector<cv::Point2d> a, b;
  for (int f = 0; f < w.frames(); ++f) {
    if (!(w.seen[best_i][f] && w.seen[best_j][f])) continue;
    for (int m = 0; m < 3; ++m) {
      a.emplace_back(n[best_i][f][m].x(), n[best_i][f][m].y());
      b.emplace_back(n[best_j][f][m].x(), n[best_j][f][m].y());
    }
  }
  const double gate = p.ransac_px / rig->cameras[best_i].K.fx_px;
  cv::Mat mask;
  const cv::Mat E =
      cv::findEssentialMat(a, b, 1.0, cv::Point2d(0, 0), cv::RANSAC, 0.999, gate, mask);
  if (E.rows != 3)
    bad("the essential matrix of " + rig->cameras[best_i].name + " and " +
        rig->cameras[best_j].name + " failed");
  cv::Mat R, t;
  cv::recoverPose(E, a, b, R, t, 1.0, cv::Point2d(0, 0), mask);
  Eigen::Matrix3d R_ji;
  Eigen::Vector3d t_ji;
  cv::cv2eigen(R, R_ji);
  cv::cv2eigen(t, t_ji);
  rig->cameras[best_i].R_CW = Eigen::Matrix3d::Identity();
  rig->cameras[best_i].p_WC = Eigen::Vector3d::Zero();
  rig->cameras[best_j].R_CW = R_ji;
  rig->cameras[best_j].p_WC = -R_ji.transpose() * t_ji;
  return {best_i, best_j};
}

// Adds every other camera by PnP on the triangulated wand, the most-seeing first.
void register_cameras(const WandObservations& w, const Normalised& n, const CalibrationParams& p,
                      std::vector<char>* registered, Rig* rig) {
  std::vector<char> ok;
  while (std::count(registered->begin(), registered->end(), 1) < w.cameras()) {
    auto points = triangulate_wand(*rig, w, n, *registered, &ok);
    int best = -1, best_count = 0;
    for (int c = 0; c < w.cameras(); ++c) {
      if ((*registered)[c]) continue;
      int count = 0;
      for (int f = 0; f < w.frames(); ++f) count += ok[f] && w.seen[c][f] ? 1 : 0;
      if (count > best_count) {
        best_count = count;
        best = c;
      }
    }
    if (best < 0 || best_count < p.min_shared_views) {
      for (int c = 0; c < w.cameras(); ++c) {
        if (!(*registered)[c])
          bad("camera " + rig->cameras[c].name +
              " saw the wand with the others in too few frames (" +
              std::to_string(std::max(best_count, 0)) + ", needs " +
              std::to_string(p.min_shared_views) + ")");
      }
    }
    std::vector<cv::Point3d> object;
    std::vector<cv::Point2d> image;
    for (int f = 0; f < w.frames(); ++f) {
      if (!(ok[f] && w.seen[best][f])) continue;
      for (int m = 0; m < 3; ++m) {
        object.emplace_back(points[f][m].x(), points[f][m].y(), points[f][m].z());
        image.emplace_back(n[best][f][m].x(), n[best][f][m].y());
      }
    }
    cv::Mat rvec, tvec;
    const float gate = static_cast<float>(p.ransac_px / rig->cameras[best].K.fx_px);
    if (!cv::solvePnPRansac(object, image, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvec, tvec, false,
                            500, gate, 0.999))
      bad("camera " + rig->cameras[best].name + ": its pose from the wand (PnP) failed");
    cv::Mat R;
    cv::Rodrigues(rvec, R);
    Eigen::Matrix3d R_CW;
    Eigen::Vector3d t;
    cv::cv2eigen(R, R_CW);
    cv::cv2eigen(tvec, t);
    rig->cameras[best].R_CW = R_CW;
    rig->cameras[best].p_WC = -R_CW.transpose() * t;
    (*registered)[best] = 1;
  }
}

// Every camera's pose and lens and every wand pose, by Ceres.
void bundle_adjust(const WandObservations& w, const Wand& wand, const CalibrationParams& p,
                   int gauge, Rig* rig, CalibrationReport* report) {
  const Normalised n = normalise(*rig, w);
  std::vector<char> all(w.cameras(), 1), ok;
  const auto points = triangulate_wand(*rig, w, n, all, &ok);
  std::vector<PoseParams> poses;
  std::vector<std::array<double, kLensParams>> lenses(w.cameras());
  for (int c = 0; c < w.cameras(); ++c) {
    poses.push_back(to_params(rig->cameras[c]));
    rig->cameras[c].K.to_array(lenses[c].data());
  }
  std::vector<std::array<double, 6>> wands(w.frames());  // A, then the unit direction A -> C
  ceres::Problem problem;
  const std::array<double, 3> offsets = wand.offsets_m();
  int frames = 0;
  for (int f = 0; f < w.frames(); ++f) {
    if (!ok[f]) continue;
    ++frames;
    const Eigen::Vector3d d = (points[f][2] - points[f][0]).normalized();
    for (int k = 0; k < 3; ++k) {
      wands[f][k] = points[f][0][k];
      wands[f][3 + k] = d[k];
    }
    for (int c = 0; c < w.cameras(); ++c) {
      if (!w.seen[c][f]) continue;
      for (int m = 0; m < 3; ++m) {
        auto* cost = new ceres::AutoDiffCostFunction<WandResidual, 2, 6, kLensParams, 3, 3>(
            new WandResidual(w.abc_px[c][f][m], offsets[m]));
        problem.AddResidualBlock(cost, new ceres::HuberLoss(p.huber_px), poses[c].aa,
                                 lenses[c].data(), wands[f].data(), wands[f].data() + 3);
      }
    }
    problem.SetManifold(wands[f].data() + 3, new ceres::SphereManifold<3>());
  }
  // The world frame is the gauge camera's; k3 stays 0 (it trades off against k1, k2).
  problem.SetParameterBlockConstant(poses[gauge].aa);
  for (int c = 0; c < w.cameras(); ++c) {
    if (!problem.HasParameterBlock(lenses[c].data()))
      bad("camera " + rig->cameras[c].name + " has no wand views");
    if (p.refine_lens)
      problem.SetManifold(lenses[c].data(), new ceres::SubsetManifold(kLensParams, {8}));
    else
      problem.SetParameterBlockConstant(lenses[c].data());
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.max_num_iterations = p.max_iterations;
  options.num_threads = 1;  // deterministic whatever the machine
  options.function_tolerance = 1e-12;
  options.parameter_tolerance = 1e-12;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  for (int c = 0; c < w.cameras(); ++c) {
    from_params(poses[c], &rig->cameras[c]);
    rig->cameras[c].K.from_array(lenses[c].data());
  }
  report->frames_used = frames;
  report->iterations = static_cast<int>(summary.iterations.size());
  report->solver = summary.BriefReport();
}

// Per camera reprojection RMS of the adjusted wand, and the wand triangulated marker by marker.
void measure(const WandObservations& w, const Wand& wand, const Rig& rig,
             CalibrationReport* report) {
  const Normalised n = normalise(rig, w);
  std::vector<char> all(w.cameras(), 1), ok;
  const auto points = triangulate_wand(rig, w, n, all, &ok);
  report->reprojection_rms_px.assign(w.cameras(), 0);
  report->wand_views.assign(w.cameras(), 0);
  double ac2 = 0;
  int frames = 0;
  for (int f = 0; f < w.frames(); ++f) {
    if (!ok[f]) continue;
    ++frames;
    const double e = (points[f][2] - points[f][0]).norm() - wand.ac_m;
    ac2 += e * e;
    for (int c = 0; c < w.cameras(); ++c) {
      if (!w.seen[c][f]) continue;
      ++report->wand_views[c];
      for (int m = 0; m < 3; ++m)
        report->reprojection_rms_px[c] +=
            (rig.cameras[c].project(points[f][m]) - w.abc_px[c][f][m]).squaredNorm();
    }
  }
  for (int c = 0; c < w.cameras(); ++c)
    report->reprojection_rms_px[c] =
        std::sqrt(report->reprojection_rms_px[c] / std::max(1, 3 * report->wand_views[c]));
  report->wand_ac_rms_mm = 1000 * std::sqrt(ac2 / std::max(frames, 1));
}

}  // namespace

void Wand::validate() const {
  if (!(ab_m > 0) || !(ac_m > ab_m) || ac_m > 5)
    bad("the wand needs 0 < ab_m < ac_m <= 5 m, got " + std::to_string(ab_m) + ", " +
        std::to_string(ac_m));
  const double ratio = ab_m / ac_m;
  // identify_wand tells the ends apart by B's place: ab/ac and 1 - ab/ac must differ by more
  // than twice its tolerance.
  if (std::abs(ratio - 0.5) <= kWandRatioTolerance)
    bad("the wand's middle marker must be off-centre: ab/ac within 0.5 +- " +
        std::to_string(kWandRatioTolerance) + " cannot tell its ends apart, got " +
        std::to_string(ratio));
}

void LFrame::validate() const {
  if (!(x1_m > 0) || !(x2_m > x1_m) || !(y_m > 0) || !(height_m >= 0))
    bad("the L-frame needs 0 < x1_m < x2_m, y_m > 0, height_m >= 0");
}

std::array<Eigen::Vector3d, 4> LFrame::points_W() const {
  return {Eigen::Vector3d(0, 0, height_m), Eigen::Vector3d(x1_m, 0, height_m),
          Eigen::Vector3d(x2_m, 0, height_m), Eigen::Vector3d(0, y_m, height_m)};
}

void CalibrationParams::validate() const {
  if (!(ransac_px > 0) || !(huber_px > 0) || max_iterations < 1 || min_shared_views < 6)
    bad("params: need ransac_px > 0, huber_px > 0, max_iterations >= 1, min_shared_views >= 6");
}

bool identify_wand(const std::vector<Blob>& blobs, const Wand& wand,
                   std::array<Eigen::Vector2d, 3>* abc_px) {
  if (blobs.size() != 3) return false;
  // The ends are the farthest pair; the middle is the third blob.
  int e0 = 0, e1 = 1, mid = 2;
  double far = 0;
  for (int i = 0; i < 3; ++i) {
    for (int j = i + 1; j < 3; ++j) {
      const double dist = (blobs[i].uv_px - blobs[j].uv_px).norm();
      if (dist > far) {
        far = dist;
        e0 = i;
        e1 = j;
        mid = 3 - i - j;
      }
    }
  }
  const Eigen::Vector2d a = blobs[e0].uv_px, c = blobs[e1].uv_px, b = blobs[mid].uv_px;
  const Eigen::Vector2d axis = (c - a) / far;
  const double off_line = std::abs(axis.x() * (b - a).y() - axis.y() * (b - a).x());
  if (far < 10 || off_line > kWandLineTolerance_px + kWandLineTolerance * far) return false;
  const double along = (b - a).dot(axis) / far;  // 0 at a, 1 at c
  const double ratio = wand.ab_m / wand.ac_m;
  if (std::abs(along - ratio) < kWandRatioTolerance) {
    *abc_px = {a, b, c};
    return true;
  }
  if (std::abs((1 - along) - ratio) < kWandRatioTolerance) {
    *abc_px = {c, b, a};
    return true;
  }
  return false;
}

Rig calibrate_from_wand(const Rig& nominal, const WandObservations& wand_seen, const Wand& wand,
                        const CalibrationParams& params, CalibrationReport* report) {
  wand.validate();
  params.validate();
  if (wand_seen.cameras() != nominal.size() || nominal.size() < 2)
    bad("the wand was seen by " + std::to_string(wand_seen.cameras()) + " cameras, the rig has " +
        std::to_string(nominal.size()) + " (at least 2 needed)");
  Rig rig = nominal;
  rig.source = "wand calibration";
  const Normalised n = normalise(rig, wand_seen);
  const auto [first, second] = initial_pair(wand_seen, n, params, &rig);
  // Scale: the pair's triangulated wand has its length.
  std::vector<char> registered(rig.size(), 0), ok;
  registered[first] = registered[second] = 1;
  const auto pair_points = triangulate_wand(rig, wand_seen, n, registered, &ok);
  std::vector<double> lengths;
  for (int f = 0; f < wand_seen.frames(); ++f) {
    if (ok[f]) lengths.push_back((pair_points[f][2] - pair_points[f][0]).norm());
  }
  if (lengths.empty()) bad("the first pair triangulated no wand frame");
  std::nth_element(lengths.begin(), lengths.begin() + lengths.size() / 2, lengths.end());
  rig.cameras[second].p_WC *= wand.ac_m / lengths[lengths.size() / 2];
  register_cameras(wand_seen, n, params, &registered, &rig);
  bundle_adjust(wand_seen, wand, params, first, &rig, report);
  measure(wand_seen, wand, rig, report);
  rig.reprojection_rms_px = report->reprojection_rms_px;
  return rig;
}

void align_to_lframe(const std::vector<std::vector<Point3>>& frames, const LFrame& lframe, Rig* rig,
                     double* fit_rms_m) {
  lframe.validate();
  const std::array<Eigen::Vector3d, 4> tmpl = lframe.points_W();
  std::array<Eigen::Vector3d, 4> sum;
  sum.fill(Eigen::Vector3d::Zero());
  int seen = 0;
  for (const std::vector<Point3>& points : frames) {
    if (points.size() < 4) continue;
    // The four points (in template order) whose six distances match the template's.
    const int n = static_cast<int>(points.size());
    std::array<int, 4> best{-1, -1, -1, -1};
    double best_err = kLFrameDistanceTolerance_m;
    std::array<int, 4> idx;
    for (idx[0] = 0; idx[0] < n; ++idx[0])
      for (idx[1] = 0; idx[1] < n; ++idx[1])
        for (idx[2] = 0; idx[2] < n; ++idx[2])
          for (idx[3] = 0; idx[3] < n; ++idx[3]) {
            double worst = 0;
            for (int i = 0; i < 4 && worst < best_err; ++i)
              for (int j = i + 1; j < 4; ++j) {
                if (idx[i] == idx[j]) {
                  worst = 1e9;
                  break;
                }
                worst = std::max(worst, std::abs((points[idx[i]].p_W - points[idx[j]].p_W).norm() -
                                                 (tmpl[i] - tmpl[j]).norm()));
              }
            if (worst < best_err) {
              best_err = worst;
              best = idx;
            }
          }
    if (best[0] < 0) continue;
    for (int i = 0; i < 4; ++i) sum[i] += points[best[i]].p_W;
    ++seen;
  }
  if (seen == 0) bad("no frame of the L-frame recording shows its four markers at their distances");
  Eigen::Matrix<double, 3, 4> measured, wanted;
  for (int i = 0; i < 4; ++i) {
    measured.col(i) = sum[i] / seen;
    wanted.col(i) = tmpl[i];
  }
  // measured = R wanted + t: the old frame F from the lab frame W.
  const Eigen::Matrix4d T = Eigen::umeyama(wanted, measured, false);
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = T.topRightCorner<3, 1>();
  double sum2 = 0;
  for (int i = 0; i < 4; ++i) sum2 += (R * wanted.col(i) + t - measured.col(i)).squaredNorm();
  *fit_rms_m = std::sqrt(sum2 / 4);
  for (Camera& c : rig->cameras) {
    c.p_WC = R.transpose() * (c.p_WC - t);
    c.R_CW = c.R_CW * R;
  }
}

}  // namespace biodyn::capture
