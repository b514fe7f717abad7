#pragma once
/// Calibrating a camera rig as commercial systems do: a wand of three markers at known
/// distances waved through the volume gives every camera's pose and lens (relative poses from
/// the essential matrix of the best camera pair, the other cameras added by PnP on the
/// triangulated wand, then a bundle adjustment over every camera's pose and lens and every wand
/// pose, Ceres, with the wand's known geometry fixing the scale); an L-frame on the floor then
/// sets the lab frame (origin at its corner, x along its long arm, z up).

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "biodyn/capture/blobs.h"
#include "biodyn/capture/camera.h"
#include "biodyn/capture/reconstruct.h"

namespace biodyn::capture {

/// Three markers on a line: A at 0, B at ab_m, C at ac_m (B off-centre, so the ends are told
/// apart). The default is a 500 mm wand (OptiTrack's CW-500 has the same span).
struct Wand {
  double ab_m = 0.16, ac_m = 0.50;
  void validate() const;  ///< throws sim::InvalidArgument naming the field
  /// m: A, B and C along the wand from A.
  std::array<double, 3> offsets_m() const { return {0.0, ab_m, ac_m}; }
};

/// An L-frame lying on the floor: its corner O, two markers along its long arm (x) and one
/// along its short arm (y); every marker's centre height_m above the floor.
struct LFrame {
  double x1_m = 0.20, x2_m = 0.45, y_m = 0.35, height_m = 0.0125;
  void validate() const;  ///< throws sim::InvalidArgument naming the field
  /// m: O, X1, X2, Y in the lab frame it defines.
  std::array<Eigen::Vector3d, 4> points_W() const;
};

/// The wand's A, B, C in one image: true when the image has exactly three blobs nearly on a
/// line with the middle one where the wand's B can be; `abc_px` gets them in order.
bool identify_wand(const std::vector<Blob>& blobs, const Wand& wand,
                   std::array<Eigen::Vector2d, 3>* abc_px);

/// The wand as each camera saw it: [camera][frame].
struct WandObservations {
  std::vector<std::vector<std::array<Eigen::Vector2d, 3>>> abc_px;
  std::vector<std::vector<char>> seen;
  int cameras() const { return static_cast<int>(seen.size()); }
  int frames() const { return seen.empty() ? 0 : static_cast<int>(seen.front().size()); }
};

struct CalibrationParams {
  double ransac_px = 3.0;     ///< px: inlier gate of the essential matrix and PnP (nominal lens)
  double huber_px = 1.0;      ///< px: the bundle adjustment's robust loss
  int max_iterations = 200;   ///< of the bundle adjustment
  int min_shared_views = 20;  ///< wand frames a camera must share with the others
  bool refine_lens = true;    ///< focal lengths, principal point, k1 k2 p1 p2 (k3 stays 0)
  void validate() const;      ///< throws sim::InvalidArgument naming the field
};

struct CalibrationReport {
  std::vector<double> reprojection_rms_px;  ///< per camera, over its wand views
  std::vector<int> wand_views;              ///< per camera: frames it saw the wand in
  int frames_used = 0;                      ///< wand frames seen by at least two cameras
  double wand_ac_rms_mm = 0;  ///< |AC| of the wand triangulated point by point, less ac_m
  int iterations = 0;
  std::string solver;            ///< Ceres's one-line report
  double lframe_fit_rms_mm = 0;  ///< the L-frame's markers against their template (align_to_lframe)
};

/// The rig from a wand wave. `nominal` names the cameras (in order) and gives each one's image
/// size and a lens guess (focal length from the lens's spec, principal point at the centre, no
/// distortion); its poses are ignored. The result's world frame is the first camera of the best
/// pair, in metres: align_to_lframe moves it to the lab. Throws sim::InvalidArgument when a
/// camera shares too few wand views with the others or the pair's geometry fails.
Rig calibrate_from_wand(const Rig& nominal, const WandObservations& wand_seen, const Wand& wand,
                        const CalibrationParams& params, CalibrationReport* report);

/// Moves `rig`'s world frame onto the L-frame: `frames` are its 3D points (Reconstructor with
/// this rig) over a still recording; in each frame the four points that match the L-frame's
/// distances are taken, averaged over the frames, and the rigid fit to LFrame::points_W() sets
/// the frame. `fit_rms_m` gets the fit's RMS. Throws sim::InvalidArgument if no frame shows the
/// L-frame.
void align_to_lframe(const std::vector<std::vector<Point3>>& frames, const LFrame& lframe, Rig* rig,
                     double* fit_rms_m);

}  // namespace biodyn::capture
