#pragma once
/// BVH (Biovision hierarchy) reader, writer and forward kinematics. Any hierarchy; per-joint
/// channel order, where rotations are intrinsic and applied in the listed order (a joint
/// listing "Zrotation Xrotation Yrotation" has R = Rz * Rx * Ry); roots with or without
/// position channels; end sites; frame time. Units and up axis are not stated in the file:
/// BvhUnits says how to read them (references.md: CMU is x 0.056444 -> metres, y up).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace biodyn::mocap_io {

/// Deepest nesting of joints the reader accepts and the writer writes: a root is at depth 1,
/// each JOINT or End Site one deeper than its parent. Skeletons are far shallower (the CMU walk
/// in ../shared/data nests 11 deep, end sites included; rigs with finger chains stay under 20);
/// the bound stops a malformed or hostile file (200,000 nested joints) from costing memory
/// quadratic in its depth (the writer's indentation: 7.9 GB, then bad_alloc).
inline constexpr int kMaxBvhDepth = 256;

/// One channel of a BVH joint.
enum class BvhChannel { kXposition, kYposition, kZposition, kXrotation, kYrotation, kZrotation };

const char* to_string(BvhChannel channel);

/// One joint (or end site) of the hierarchy, in file order (parents before children).
struct BvhJoint {
  std::string name;  ///< "End Site" joints get "<parent>_end"
  int parent = -1;   ///< index into BvhMotion::joints; -1 for a root
  bool end_site = false;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< file units, parent frame
  std::vector<BvhChannel> channels;                  ///< in the listed order; empty for end sites
  int first_channel = 0;                             ///< index of channels[0] in a frame's values
};

/// A BVH file: hierarchy and motion, values exactly as in the file (file units, degrees).
struct BvhMotion {
  std::vector<BvhJoint> joints;
  double frame_time_s = 0.0;  ///< s, > 0
  /// frames x channel_count(): each frame's values in file order (positions in file units,
  /// rotations in degrees).
  Eigen::MatrixXd values;
  /// Joint names that were not UTF-8 in the file, read as Latin-1 (to_utf8 in utf8.h); every
  /// name here is UTF-8.
  int transcoded_names = 0;

  int frame_count() const { return static_cast<int>(values.rows()); }
  int channel_count() const { return static_cast<int>(values.cols()); }
  /// Index of the joint named `name`, or -1.
  int find(const std::string& name) const;
};

/// Vertical axis of a BVH file's world frame.
enum class UpAxis { kY, kZ };

/// How to interpret a BVH file's units and axes when mapping it to biodyn's world (z up,
/// metres). With kY up, file (x, y, z) maps to world (z, x, y) (a right-handed rotation: the
/// file's forward +z becomes world +x, the file's up +y becomes world +z).
struct BvhUnits {
  double metres_per_unit = 0.01;  ///< m per file length unit (cm is the most common)
  UpAxis up = UpAxis::kY;
  /// CMU motion-capture database preset (references.md: x 0.056444 -> m, y up).
  static BvhUnits cmu() { return {0.056444, UpAxis::kY}; }
};

/// Parses BVH text; `source` names the file in errors. Throws ParseError naming the line, what
/// was expected and what was found (unknown keyword, wrong channel count, missing frames,
/// non-number, a frame with too few or too many values, ...).
///
/// The hierarchy is whitespace-separated words and braces (CRLF, tabs, blank lines and a UTF-8
/// BOM are fine; keywords and channel names match ignoring case); a ROOT/JOINT name is the rest of
/// its line; every ROOT and JOINT has OFFSET then CHANNELS (0-6 distinct channels, any order); any
/// number of ROOTs, joints nested at most kMaxBvhDepth deep. "Frames:" must be > 0 and "Frame
/// Time:" > 0. Each frame is one line of exactly channel_count() values (as BVH writers put them),
/// so a short or long frame is reported on its own line; blank lines are skipped; nothing may
/// follow the last frame. Never returns a partial motion.
BvhMotion parse_bvh(const std::string& text, const std::string& source);
/// Reads a BVH file (parse_bvh on its contents; sim::InvalidArgument if it cannot be read).
BvhMotion read_bvh(const std::string& path);

/// BVH text of `motion` with values printed to `precision` significant digits (parse_bvh of the
/// result reproduces the values to that precision; 10 digits keeps a round trip to 1e-6).
/// Joints must be in depth-first file order (as parse_bvh makes them); end sites are written as
/// "End Site" and read back named "<parent>_end". Throws sim::InvalidArgument for a motion that
/// cannot be written (inconsistent hierarchy or channels, joints nested deeper than kMaxBvhDepth,
/// no frames, frame time <= 0, non-finite values, a name with a line break or brace, precision
/// outside 1-17).
std::string format_bvh(const BvhMotion& motion, int precision = 10);
/// Writes format_bvh(motion) to `path` whole or not at all (via "<path>.tmp" and a rename);
/// throws sim::Error naming `path` if it cannot (sim::InvalidArgument as format_bvh).
void write_bvh(const std::string& path, const BvhMotion& motion, int precision = 10);

/// Local rotation of joint j at frame f (its rotation channels composed intrinsically in listed
/// order) as a rotation matrix in the file's axes. Throws sim::InvalidArgument if j or f is out
/// of range.
Eigen::Matrix3d local_rotation(const BvhMotion& motion, int j, int f);

/// World poses of every joint (and end site) at frame f, in biodyn's world (metres, z up) per
/// `units`: positions (3 x joints) and orientations (rotation from the joint's frame, in file
/// axes, to the world).
struct BvhPose {
  Eigen::Matrix3Xd positions_W;              ///< m, world frame, 3 x joints
  std::vector<Eigen::Matrix3d> rotations_W;  ///< one per joint: R_WJ, joint axes -> world
};
/// Forward kinematics of frame f. A joint's origin in its parent's frame is its OFFSET, except
/// that each axis with a position channel takes the channel's value instead (the channel *is*
/// the translation, OFFSET its rest value: Blender's importer and exporter; bvh11 and three.js
/// add the two, which agrees whenever such a joint's OFFSET is zero, as for CMU's root).
/// Translation is in the parent's frame wherever the position channels are listed; rotation is
/// local_rotation. Throws sim::InvalidArgument for f out of range, metres_per_unit <= 0 or an
/// inconsistent hand-built motion (a parent after its child, channels not tiling the values).
BvhPose forward_kinematics(const BvhMotion& motion, int f, const BvhUnits& units);

/// The rotation from the file's axes to biodyn's world axes for `up`.
Eigen::Matrix3d file_to_world(UpAxis up);

}  // namespace biodyn::mocap_io
