#include "biodyn/mocap_io/marker_labels.h"

#include <algorithm>
#include <map>

#include "biodyn/sim/errors.h"

namespace biodyn::mocap_io {

std::vector<std::string> strip_subject_prefixes(MarkerData* markers) {
  std::vector<std::string> prefixes;
  std::map<std::string, std::string> bare_to_label;
  std::vector<std::string> stripped;
  for (const std::string& label : markers->labels) {
    const size_t colon = label.rfind(':');
    std::string bare = label;
    if (colon != std::string::npos && colon + 1 < label.size()) {
      const std::string prefix = label.substr(0, colon);
      if (std::find(prefixes.begin(), prefixes.end(), prefix) == prefixes.end()) {
        prefixes.push_back(prefix);
      }
      bare = label.substr(colon + 1);
    }
    const auto [it, fresh] = bare_to_label.emplace(bare, label);
    if (!fresh) {
      throw sim::InvalidArgument("capture labels '" + it->second + "' and '" + label +
                                 "' are the same marker without their subject prefix: a capture "
                                 "of two subjects? Keep one subject's markers, or give a marker "
                                 "set naming the labels as the capture does");
    }
    stripped.push_back(bare);
  }
  if (!prefixes.empty()) markers->labels = stripped;
  return prefixes;
}

std::string label_list(const std::vector<std::string>& labels, size_t limit) {
  std::string out;
  for (size_t i = 0; i < labels.size() && i < limit; ++i) out += (i ? ", " : "") + labels[i];
  if (labels.size() > limit) out += ", ... (" + std::to_string(labels.size() - limit) + " more)";
  return out;
}

}  // namespace biodyn::mocap_io
