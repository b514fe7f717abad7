#pragma once
/// Capture labels against marker-set names. Capture software prefixes labels with the subject
/// ("Subject:LASI", Vicon Nexus); marker sets name the bare marker. BVH joint maps ignore such a
/// prefix the same way (retarget.h).

#include <string>
#include <vector>

#include "biodyn/mocap_io/marker_data.h"

namespace biodyn::mocap_io {

/// Removes a "<subject>:" prefix (everything up to the last ':') from every label of `markers`
/// and returns the distinct prefixes removed (without ':'), empty when no label had one.
/// Throws sim::InvalidArgument naming both labels when two would become the same (two subjects
/// in one capture: keep the one to solve with `mocap convert`, or give a marker set naming the
/// prefixed labels).
std::vector<std::string> strip_subject_prefixes(MarkerData* markers);

/// The labels as one line for messages: "LASI, RASI, ..." (at most `limit`, then "... (N more)").
std::string label_list(const std::vector<std::string>& labels, size_t limit = 60);

}  // namespace biodyn::mocap_io
