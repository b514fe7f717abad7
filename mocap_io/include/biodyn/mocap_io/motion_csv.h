#pragma once
/// Joint trajectories of a character as CSV: one row per frame, `time` then the model's qpos
/// in MuJoCo's order, columns named after the joints (free root: <body>_x, _y, _z, _qw, _qx,
/// _qy, _qz; ball: <joint>_qw ... _qz; hinge/slide: <joint>). Angles in radians, positions in
/// metres, quaternions (w, x, y, z). '#' lines are comments (the writer records the body and
/// the source there). An unsolved frame is a row of "nan".

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "biodyn/models/character.h"

namespace biodyn::mocap_io {

struct Motion {
  std::vector<std::string> columns;   ///< qpos names (without "time"), nq of them
  std::vector<double> times_s;        ///< s, one per frame
  Eigen::MatrixXd qpos;               ///< frames x nq (NaN rows: unsolved frames)
  std::vector<std::string> comments;  ///< the '#' lines, without the '#'

  int frame_count() const { return static_cast<int>(qpos.rows()); }
};

/// qpos column names of `model` (see the file comment).
std::vector<std::string> qpos_names(const mjModel& model);

/// CSV text of `motion` (comments first, 17 significant digits: a round trip is exact).
std::string format_motion_csv(const Motion& motion);
/// Parses motion CSV; `source` names the file in errors. Throws ParseError naming the line, the
/// column, what was expected and what was found.
Motion parse_motion_csv(const std::string& text, const std::string& source);
Motion read_motion_csv(const std::string& path);

/// The body header: a comment line " body: {...}" holding the body file (models/body_file.h,
/// one line) of the character the motion was made on, so `mocap id` and the viewer use that
/// body. set_motion_body replaces an existing one.
void set_motion_body(Motion* motion, const models::CharacterSpec& spec);
/// The body of `motion`'s header, or nothing for a motion without one (older files, hand-made
/// ones). Throws sim::InvalidArgument naming `source` and the field if the header is malformed.
std::optional<models::CharacterSpec> motion_body(const Motion& motion, const std::string& source);

/// Checks that `motion`'s columns are `model`'s qpos names; throws sim::InvalidArgument naming
/// the first column that differs (a motion made for another detail level or body plan).
void check_motion_matches(const Motion& motion, const mjModel& model, const std::string& source);

/// The longest run of frames without a gap (an unsolved IK frame is a row of NaN): what finite
/// differences and tracking can use. `first` (optional) gets its first frame's index.
Motion longest_solved_span(const Motion& motion, int* first = nullptr);

}  // namespace biodyn::mocap_io
