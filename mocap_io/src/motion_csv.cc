#include "biodyn/mocap_io/motion_csv.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "biodyn/mocap_io/errors.h"
#include "biodyn/models/body_file.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"

namespace biodyn::mocap_io {
std::vector<std::string> qpos_names(const mjModel& m) {
  std::vector<std::string> names;
  for (int j = 0; j < m.njnt; ++j) {
    const char* jn = mj_id2name(&m, mjOBJ_JOINT, j);
    const std::string joint = jn ? jn : "joint" + std::to_string(j);
    switch (m.jnt_type[j]) {
      case mjJNT_FREE: {
        const char* bn = mj_id2name(&m, mjOBJ_BODY, m.jnt_bodyid[j]);
        const std::string body = bn ? bn : joint;
        for (const char* s : {"_x", "_y", "_z", "_qw", "_qx", "_qy", "_qz"})
          names.push_back(body + s);
        break;
      }
      case mjJNT_BALL:
        for (const char* s : {"_qw", "_qx", "_qy", "_qz"}) names.push_back(joint + s);
        break;
      default:
        names.push_back(joint);
    }
  }
  return names;
}

std::string format_motion_csv(const Motion& motion) {
  std::ostringstream out;
  out.precision(17);
  for (const std::string& c : motion.comments) out << "#" << c << "\n";
  out << "time";
  for (const std::string& c : motion.columns) out << "," << c;
  out << "\n";
  for (int f = 0; f < motion.frame_count(); ++f) {
    out << motion.times_s[static_cast<size_t>(f)];
    for (Eigen::Index k = 0; k < motion.qpos.cols(); ++k) {
      const double v = motion.qpos(f, k);
      out << ",";
      if (std::isnan(v)) {
        out << "nan";
      } else {
        out << v;
      }
    }
    out << "\n";
  }
  return out.str();
}

Motion parse_motion_csv(const std::string& text, const std::string& source) {
  Motion motion;
  std::istringstream in(text);
  std::string line;
  long number = 0;
  bool header = false;
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    if (line[0] == '#') {
      motion.comments.push_back(line.substr(1));
      continue;
    }
    const std::vector<std::string> fields = sim::split_fields(line);
    if (!header) {
      if (fields.empty() || fields[0] != "time" || fields.size() < 2) {
        throw ParseError(source, ParseError::line(number), "a header 'time,<qpos names>'",
                         "'" + line.substr(0, 60) + "'");
      }
      motion.columns.assign(fields.begin() + 1, fields.end());
      header = true;
      continue;
    }
    if (fields.size() != motion.columns.size() + 1) {
      throw ParseError(source, ParseError::line(number),
                       std::to_string(motion.columns.size() + 1) + " fields",
                       std::to_string(fields.size()) + " fields");
    }
    std::vector<double> row(fields.size());
    for (size_t k = 0; k < fields.size(); ++k) {
      errno = 0;
      char* end = nullptr;
      row[k] = std::strtod(fields[k].c_str(), &end);
      if (fields[k].empty() || *end != '\0' || errno == ERANGE ||
          (k == 0 && !std::isfinite(row[k]))) {
        throw ParseError(
            source, ParseError::line(number),
            "a number in column " + (k == 0 ? std::string("time") : motion.columns[k - 1]),
            "'" + fields[k] + "'");
      }
    }
    if (!motion.times_s.empty() && !(row[0] > motion.times_s.back())) {
      throw ParseError(source, ParseError::line(number), "a time after the previous row's",
                       fields[0]);
    }
    motion.times_s.push_back(row[0]);
    rows.push_back(std::move(row));
  }
  if (!header)
    throw ParseError(source, ParseError::line(number + 1), "a header line", "end of file");
  if (rows.empty())
    throw ParseError(source, ParseError::line(number + 1), "data rows", "end of file");
  motion.qpos.resize(static_cast<Eigen::Index>(rows.size()),
                     static_cast<Eigen::Index>(motion.columns.size()));
  for (size_t f = 0; f < rows.size(); ++f) {
    for (size_t k = 0; k < motion.columns.size(); ++k) {
      motion.qpos(static_cast<Eigen::Index>(f), static_cast<Eigen::Index>(k)) = rows[f][k + 1];
    }
  }
  return motion;
}

namespace {
const std::string kBodyPrefix = " body: ";
}  // namespace

void set_motion_body(Motion* motion, const models::CharacterSpec& spec) {
  std::vector<std::string>& c = motion->comments;
  c.erase(std::remove_if(c.begin(), c.end(),
                         [](const std::string& s) { return s.rfind(kBodyPrefix, 0) == 0; }),
          c.end());
  c.push_back(kBodyPrefix + models::format_body_json(spec, true));
}

std::optional<models::CharacterSpec> motion_body(const Motion& motion, const std::string& source) {
  for (const std::string& s : motion.comments) {
    if (s.rfind(kBodyPrefix, 0) != 0) continue;
    return models::parse_body_json(s.substr(kBodyPrefix.size()), source + ": body header");
  }
  return std::nullopt;
}

Motion read_motion_csv(const std::string& path) {
  return parse_motion_csv(sim::read_file(path), path);
}

void check_motion_matches(const Motion& motion, const mjModel& model, const std::string& source) {
  const std::vector<std::string> names = qpos_names(model);
  if (motion.columns.size() != names.size()) {
    throw sim::InvalidArgument(source + ": has " + std::to_string(motion.columns.size()) +
                               " qpos columns, the character has " + std::to_string(names.size()) +
                               " (a motion for another detail level?)");
  }
  for (size_t k = 0; k < names.size(); ++k) {
    if (motion.columns[k] != names[k]) {
      throw sim::InvalidArgument(source + ": column " + std::to_string(k + 2) + " is '" +
                                 motion.columns[k] + "', the character's qpos " +
                                 std::to_string(k) + " is '" + names[k] + "'");
    }
  }
}

Motion longest_solved_span(const Motion& motion, int* first) {
  int best_start = 0, best_len = 0, start = 0;
  for (int f = 0; f <= motion.frame_count(); ++f) {
    const bool ok = f < motion.frame_count() && motion.qpos.row(f).allFinite();
    if (ok) continue;
    if (f - start > best_len) {
      best_len = f - start;
      best_start = start;
    }
    start = f + 1;
  }
  Motion out = motion;
  out.qpos = motion.qpos.middleRows(best_start, best_len);
  out.times_s.assign(motion.times_s.begin() + best_start,
                     motion.times_s.begin() + best_start + best_len);
  if (first) *first = best_start;
  return out;
}

}  // namespace biodyn::mocap_io
