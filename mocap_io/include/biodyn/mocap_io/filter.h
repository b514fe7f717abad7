#pragma once
/// Low-pass filtering of captured trajectories: joint angles before inverse dynamics, marker
/// trajectories before marker IK (the usual 6 Hz for gait kinematics, Winter 2009 §3.4).

#include <Eigen/Core>
#include <vector>

#include "biodyn/mocap_io/marker_data.h"

namespace biodyn::mocap_io {

/// Zero-lag low-pass: a 2nd-order Butterworth run forward and backward (4th order, no phase
/// lag), the cut-off corrected for the double pass (Winter 2009, §3.4.4.4: f / 0.802).
struct LowPassFilter {
  double cutoff_hz = 6.0;  ///< Hz; Winter 2009 uses ~6 Hz for gait kinematics; 0: no filtering
};

/// Hz: the cut-off one pass runs at so that the double pass has `filter`'s (the /0.802
/// correction). Throws sim::InvalidArgument when the asked cut-off is not positive or, so
/// corrected, not below the Nyquist frequency of `rate_hz`.
double single_pass_cutoff_hz(const LowPassFilter& filter, double rate_hz);

/// Filters each column of `samples` (rows at `rate_hz`) in place. Ends are padded by odd
/// reflection so they do not ring. Throws sim::InvalidArgument if the cut-off is not below the
/// Nyquist frequency.
void low_pass(Eigen::MatrixXd* samples, double rate_hz, const LowPassFilter& filter);

/// Filters every marker's trajectory in place, each unbroken run of samples on its own (a gap
/// stays a gap and nothing is carried across it), frames taken as evenly spaced at rate_hz.
/// Throws sim::InvalidArgument as low_pass does.
void low_pass_markers(MarkerData* markers, const LowPassFilter& filter);

/// Hz: the cut-off Winter's residual analysis (Winter 2009, §3.4.4.3) picks for marker `m`:
/// the RMS difference between the trajectory and its filtered self, over cut-offs from 1 Hz up,
/// is a straight line where only noise is removed (the top third of the range); the line's
/// value at 0 Hz is the noise, and the cut-off is the lowest whose residual falls to it.
/// The range is 1 Hz to 25 Hz or 0.6 of the corrected Nyquist frequency, whichever is lower
/// (24 Hz at 100 Hz); noise-free data gets its top. Fewer than 20 samples in runs, or a frame
/// rate under ~15 Hz: 0 (leave unfiltered).
double residual_cutoff_hz(const MarkerData& markers, int m);

/// Filters every marker at the cut-off residual_cutoff_hz picks for it; the cut-offs go to
/// `cutoffs_hz` (one per marker, 0: left unfiltered) when given.
void low_pass_markers_auto(MarkerData* markers, std::vector<double>* cutoffs_hz = nullptr);

}  // namespace biodyn::mocap_io
