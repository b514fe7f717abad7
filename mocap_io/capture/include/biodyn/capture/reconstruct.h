#pragma once
/// Unlabelled 3D markers from the blobs of several calibrated cameras (the thesis's multi-view
/// stage): blob pairs matched along epipolar lines within a pixel gate, triangulated, supported
/// by the other cameras whose blobs lie near the point's projection, refined by least squares
/// over every supporting view, and the worst view dropped while the point's reprojection error
/// is too large. Points seen by more cameras are taken first; a blob belongs to one point.

#include <Eigen/Core>
#include <utility>
#include <vector>

#include "biodyn/capture/blobs.h"
#include "biodyn/capture/camera.h"

namespace biodyn::capture {

struct ReconstructionParams {
  /// px: two blobs of a camera pair match when each lies this close to the other's epipolar
  /// line
  double epipolar_gate_px = 2.0;
  /// px: another camera supports a point when one of its blobs lies this close to the point's
  /// projection
  double support_gate_px = 2.5;
  int min_views = 2;  ///< cameras a point needs (2: any pair; 3: fewer ghost points)
  /// px: a point's views whose reprojection error exceeds this are dropped, worst first, while
  /// min_views remain; a point whose error stays above it is dropped
  double max_residual_px = 1.5;
  /// A point must lie in this box of the world (m): the capture volume with room to spare.
  Eigen::Vector3d volume_min_W = Eigen::Vector3d(-5, -5, -0.2);
  Eigen::Vector3d volume_max_W = Eigen::Vector3d(5, 5, 3.0);
  void validate() const;  ///< throws sim::InvalidArgument naming the field
};

/// A reconstructed (unlabelled) marker.
struct Point3 {
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();  ///< m
  std::vector<std::pair<int, int>> views;         ///< (camera, blob index) that see it
  double residual_px = 0;                         ///< RMS reprojection error over its views
};

/// The least-squares point seen along `views` (camera index, normalised image point (X/Z, Y/Z):
/// Camera::undistort of its pixel): linear, then Gauss–Newton on the reprojection error. Its RMS
/// reprojection error in pixels goes to `residual_px`. False if fewer than 2 views or the point
/// is behind a camera.
bool triangulate_normalised(const Rig& rig,
                            const std::vector<std::pair<int, Eigen::Vector2d>>& views,
                            Eigen::Vector3d* p_W, double* residual_px);

/// Reconstructs frames of one rig. Keeps its scratch between frames.
class Reconstructor {
 public:
  /// Throws sim::InvalidArgument for bad params or a rig of fewer than 2 cameras.
  Reconstructor(const Rig& rig, const ReconstructionParams& params = {});
  /// The points of one frame: `blobs[c]` are camera c's. With `tracks` (tracks[c][b]: the 2D
  /// track id of camera c's blob b, tracking2d.h), each of the last frame's points is rebuilt
  /// from the blobs that continue its 2D tracks in two or more cameras (within
  /// kMaxContinuedStep_m of where it was) and taken before any new match: a pair of blobs that
  /// happens to meet on an epipolar line (a ghost) does not take its blobs. Throws
  /// sim::InvalidArgument if there are not as many blob (or track) lists as cameras.
  void reconstruct(const std::vector<std::vector<Blob>>& blobs, std::vector<Point3>* points,
                   const std::vector<std::vector<int>>* tracks = nullptr);
  /// Points of the last reconstruct() that continue a point of the frame before along its 2D
  /// tracks.
  int continued_points() const { return continued_; }
  const Rig& rig() const { return rig_; }

 private:
  struct Candidate {
    Eigen::Vector3d p_W;
    std::vector<std::pair<int, int>> views;
    double residual_px;
    int continues = -1;  ///< the last frame's point it continues along the 2D tracks, or -1
  };
  /// Least-squares point of `views` (normalised coordinates of each camera's blobs); its RMS
  /// reprojection error in pixels into `residual_px`. False if it is behind a camera.
  bool triangulate(const std::vector<std::pair<int, int>>& views, Eigen::Vector3d* p_W,
                   double* residual_px) const;
  /// Whether blob u = (camera, blob) and blob v of another camera lie within the epipolar
  /// gate of each other's epipolar lines.
  bool epipolar_match(std::pair<int, int> u, std::pair<int, int> v) const;
  void gather_support(Candidate* c) const;
  bool refine(Candidate* c) const;
  /// Accepts `c`: its blobs are used, the point goes to `points`.
  void accept(const Candidate& c, std::vector<Point3>* points);
  /// Candidates for the last frame's points along their 2D tracks (`continues` set).
  void continue_tracked(const std::vector<std::vector<int>>& tracks);
  /// Whether continued candidate `c` lies within a frame's step of the point it continues and,
  /// seen by two cameras, passes the epipolar gate.
  bool continuation_holds(const Candidate& c) const;
  /// Each of `points`' views as (camera, track id), for the next frame.
  void remember_tracks(const std::vector<std::vector<int>>* tracks,
                       const std::vector<Point3>& points);

  Rig rig_;
  ReconstructionParams params_;
  std::vector<Eigen::Matrix3d> essential_;  ///< [i * n + j]: x_j^T E x_i = 0, normalised coords
  std::vector<std::vector<Eigen::Vector2d>> normalised_;  ///< per camera, per blob
  std::vector<std::vector<char>> used_;
  mutable std::vector<std::pair<int, Eigen::Vector2d>> scratch_;
  std::vector<Candidate> candidates_;
  /// The last frame's points: where, and their views as (camera, 2D track id).
  std::vector<Eigen::Vector3d> last_points_;
  std::vector<std::vector<std::pair<int, int>>> last_tracks_;
  int continued_ = 0;
};

/// m: a point continued along its 2D tracks lies at most this far from where it was a frame
/// ago (a foot at 5 m/s moves 5 cm at 100 Hz).
inline constexpr double kMaxContinuedStep_m = 0.10;

}  // namespace biodyn::capture
