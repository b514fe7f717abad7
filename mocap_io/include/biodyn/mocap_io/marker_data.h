#pragma once
/// In-memory capture data shared by the readers and writers: marker trajectories, analog
/// channels and force plates. SI units inside (metres, newtons, N m); every reader converts at
/// the file boundary and keeps the file's own lab frame (no axis change: that is the caller's
/// choice, see LabFrame in markerset.h).

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <vector>

namespace biodyn::mocap_io {

/// Labelled 3D marker trajectories sampled at a fixed rate.
struct MarkerData {
  double rate_hz = 0.0;  ///< Hz, frames per second, > 0
  /// Number of the first frame in the original capture (C3D header word 4, TRC's first
  /// Frame#); frame f of this data is capture frame first_frame + f.
  int first_frame = 1;
  std::vector<std::string> labels;  ///< one per marker, in file order
  /// m, lab frame of the file; frames x (3 * markers): row f holds x, y, z of marker 0, then
  /// marker 1, ... A gap (invalid or missing sample) is NaN in all three coordinates.
  Eigen::MatrixXd positions_m;
  /// s, time of each frame as the file states it (TRC's Time column), relative to nothing in
  /// particular; empty when frames are evenly spaced at rate_hz from 0 (C3D, BVH).
  std::vector<double> times_s;

  int frame_count() const { return static_cast<int>(positions_m.rows()); }
  int marker_count() const { return static_cast<int>(labels.size()); }
  /// s, time of frame f: times_s[f] when the file gave times, else f / rate_hz.
  double time_s(int f) const { return times_s.empty() ? f / rate_hz : times_s[f]; }
  /// m, position of marker m at frame f (NaN when it is a gap).
  Eigen::Vector3d position(int f, int m) const {
    return positions_m.row(f).segment<3>(3 * m).transpose();
  }
  bool visible(int f, int m) const { return !std::isnan(positions_m(f, 3 * m)); }
  /// Index of the marker labelled `label`, or -1.
  int find(const std::string& label) const {
    for (size_t i = 0; i < labels.size(); ++i) {
      if (labels[i] == label) return static_cast<int>(i);
    }
    return -1;
  }
  /// Number of frames in which marker m is a gap.
  int gap_count(int m) const {
    int n = 0;
    for (int f = 0; f < frame_count(); ++f) n += visible(f, m) ? 0 : 1;
    return n;
  }
};

/// Analog channels (force plates, EMG, ...) sampled at an integer multiple of the marker rate.
struct AnalogData {
  double rate_hz = 0.0;             ///< Hz, samples per second (0 when there are no channels)
  std::vector<std::string> labels;  ///< one per channel
  std::vector<std::string> units;   ///< as the file states them (e.g. "N", "Nmm", "V")
  /// samples x channels, in the stated units after the file's offsets and scales are applied.
  Eigen::MatrixXd values;

  int sample_count() const { return static_cast<int>(values.rows()); }
  int channel_count() const { return static_cast<int>(labels.size()); }
};

/// One force plate's ground reaction, per analog sample, in the lab frame (SI units).
///
/// Sign: force_N is the GROUND REACTION, the force the plate exerts on the subject (upward while
/// standing on a level plate), not the force the subject applies to the plate (its opposite).
/// This is what OpenSim (ExternalLoads), ezc3d, BTK and Visual3D report and what a simulation
/// applies to the body; the moments are those of this same force.
struct ForcePlate {
  int type = 0;  ///< C3D FORCE_PLATFORM:TYPE (1-4)
  /// m, lab frame; the four surface corners (columns) in the file's order.
  Eigen::Matrix<double, 3, 4> corners_m = Eigen::Matrix<double, 3, 4>::Zero();
  /// m, the C3D FORCE_PLATFORM:ORIGIN vector (plate frame), as stored, converted to metres.
  Eigen::Vector3d origin_m = Eigen::Vector3d::Zero();
  std::vector<int> channels;  ///< 0-based analog channel indices the plate reads
  /// samples x 3 (one row per analog sample), in the lab frame:
  Eigen::MatrixXd force_N;  ///< N, ground reaction: the force the plate exerts on the subject
  /// N m, moment of the ground reaction about the plate's surface centre, center_m() (not the
  /// sensor origin despite the name)
  Eigen::MatrixXd moment_origin_Nm;
  /// m, centre of pressure on the surface; NaN while the plate is unloaded (normal ground
  /// reaction below 20 N, kUnloadedForce_N in mocap_io/src/c3d_force_plates.h)
  Eigen::MatrixXd cop_m;
  /// N m, moment of the ground reaction about the COP (only the part normal to the plate is
  /// nonzero); NaN while unloaded
  Eigen::MatrixXd free_moment_Nm;

  int sample_count() const { return static_cast<int>(force_N.rows()); }
  /// m, lab frame: the centre of the plate's surface (mean of the corners).
  Eigen::Vector3d center_m() const { return corners_m.rowwise().mean(); }
};

}  // namespace biodyn::mocap_io
