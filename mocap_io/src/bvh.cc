#include "biodyn/mocap_io/bvh.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string_view>
#include <system_error>
#include <utility>

#include "biodyn/mocap_io/errors.h"
#include "biodyn/mocap_io/utf8.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"
#include "biodyn/sim/units.h"

namespace biodyn::mocap_io {
namespace {

/// A joint lists each of the six channels at most once.
constexpr int kMaxChannels = 6;
/// Longest piece of a bad token quoted in an error message.
constexpr std::size_t kMaxQuotedChars = 40;
/// The UTF-8 byte order mark some Windows editors put in front of text files.
constexpr std::string_view kUtf8Bom = "\xEF\xBB\xBF";

struct ChannelName {
  BvhChannel channel;
  const char* name;
};
constexpr ChannelName kChannelNames[] = {
    {BvhChannel::kXposition, "Xposition"}, {BvhChannel::kYposition, "Yposition"},
    {BvhChannel::kZposition, "Zposition"}, {BvhChannel::kXrotation, "Xrotation"},
    {BvhChannel::kYrotation, "Yrotation"}, {BvhChannel::kZrotation, "Zrotation"},
};
constexpr const char* kChannelList =
    "a channel name (Xposition, Yposition, Zposition, Xrotation, Yrotation or Zrotation)";

bool is_position(BvhChannel c) {
  return c == BvhChannel::kXposition || c == BvhChannel::kYposition || c == BvhChannel::kZposition;
}

/// 0, 1, 2 for a channel along or about x, y, z.
int axis_of(BvhChannel c) {
  switch (c) {
    case BvhChannel::kXposition:
    case BvhChannel::kXrotation:
      return 0;
    case BvhChannel::kYposition:
    case BvhChannel::kYrotation:
      return 1;
    case BvhChannel::kZposition:
    case BvhChannel::kZrotation:
      return 2;
  }
  return 0;
}

/// Keywords and channel names are matched ignoring case, as Blender's importer does.
bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(a[i])) !=
        std::tolower(static_cast<unsigned char>(b[i]))) {
      return false;
    }
  }
  return true;
}

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

bool is_brace(char c) { return c == '{' || c == '}'; }

/// One whitespace-separated word of the file and the line it is on.
struct Token {
  std::string_view text;  ///< empty at the end of the file
  long line = 1;          ///< 1-based
  bool end() const { return text.empty(); }
};

/// How a token reads in an error message: quoted, shortened, non-printable bytes as '?' (the
/// input may be any bytes).
std::string describe(const Token& t) {
  if (t.end()) return "end of file";
  std::string s;
  for (char c : t.text.substr(0, kMaxQuotedChars)) {
    s += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  }
  if (t.text.size() > kMaxQuotedChars) s += "...";
  return "'" + s + "'";
}

/// Splits BVH text into whitespace-separated words and braces, with one of look-ahead, counting
/// lines by '\n' (the '\r' of CRLF is plain whitespace, so CRLF, LF and mixed files number alike).
class Tokenizer {
 public:
  Tokenizer(std::string_view text, std::string source) : text_(text), source_(std::move(source)) {
    if (text_.substr(0, kUtf8Bom.size()) == kUtf8Bom) pos_ = kUtf8Bom.size();
    ahead_ = scan();
  }

  const Token& peek() const { return ahead_; }
  Token next() {
    Token t = ahead_;
    ahead_ = scan();
    return t;
  }

  [[noreturn]] void fail(long line, const std::string& expected, const std::string& found) const {
    throw ParseError(source_, ParseError::line(line), expected, found);
  }
  [[noreturn]] void fail(const Token& at, const std::string& expected) const {
    fail(at.line, expected, describe(at));
  }

  /// The next token, which must be `keyword` (ignoring case).
  Token expect(std::string_view keyword) {
    Token t = next();
    if (!iequals(t.text, keyword)) {
      fail(t, keyword == "{" || keyword == "}" ? "'" + std::string(keyword) + "'"
                                               : std::string(keyword));
    }
    return t;
  }

 private:
  Token scan() {
    while (pos_ < text_.size() && is_space(text_[pos_])) {
      if (text_[pos_] == '\n') ++line_;
      ++pos_;
    }
    const std::size_t start = pos_;
    if (pos_ < text_.size() && is_brace(text_[pos_])) {
      ++pos_;  // a brace is a word of its own: "Hips{" and "}}" read as they look
    } else {
      while (pos_ < text_.size() && !is_space(text_[pos_]) && !is_brace(text_[pos_])) ++pos_;
    }
    Token t{text_.substr(start, pos_ - start), line_};
    // The end of the file is reported on its last line, not on the empty one after a final '\n'.
    if (t.end() && line_ > 1 && !text_.empty() && text_.back() == '\n') --t.line;
    return t;
  }

  std::string_view text_;
  std::string source_;
  std::size_t pos_ = 0;
  long line_ = 1;
  Token ahead_;
};

/// `t` as a finite double (a leading '+' allowed; locale-independent), or nothing.
bool to_double(std::string_view t, double* out) {
  if (t.size() > 1 && t[0] == '+' && t[1] != '-') t.remove_prefix(1);
  const char* last = t.data() + t.size();
  const auto [ptr, ec] = std::from_chars(t.data(), last, *out);
  return ec == std::errc() && ptr == last && std::isfinite(*out);
}

/// `t` as a whole number, or nothing.
bool to_long(std::string_view t, long long* out) {
  if (t.size() > 1 && t[0] == '+' && t[1] != '-') t.remove_prefix(1);
  const char* last = t.data() + t.size();
  const auto [ptr, ec] = std::from_chars(t.data(), last, *out);
  return ec == std::errc() && ptr == last;
}

/// Reader of the grammar below. Nesting is tracked with an explicit stack of open joints, not
/// recursion, so that no input, however deeply nested, can exhaust the call stack.
///
///   file    := HIERARCHY root+ MOTION Frames: n Frame Time: dt frame*n
///   root    := ROOT name joint-body
///   joint   := JOINT name joint-body
///   body    := { OFFSET x y z CHANNELS k channel*k (joint | end)* }
///   end     := End Site { OFFSET x y z }
///   frame   := one line of exactly channel_count() numbers
class Parser {
 public:
  Parser(std::string_view text, const std::string& source)
      : tok_(text, source), text_size_(text.size()) {}

  BvhMotion parse() {
    tok_.expect("HIERARCHY");
    parse_hierarchy();
    parse_motion_header();
    parse_frames();
    return std::move(motion_);
  }

 private:
  void parse_hierarchy() {
    std::vector<int> open;  // joints whose closing '}' is still to come
    while (true) {
      const Token t = tok_.next();
      if (open.empty()) {
        if (iequals(t.text, "ROOT")) {
          open.push_back(begin_joint(t, -1, false));
        } else if (iequals(t.text, "MOTION") && !motion_.joints.empty()) {
          return;
        } else {
          tok_.fail(t, motion_.joints.empty() ? "ROOT" : "ROOT or MOTION");
        }
      } else if (t.text == "}") {
        open.pop_back();
      } else if (motion_.joints[open.back()].end_site) {
        tok_.fail(t, "'}' closing the End Site");
      } else if (iequals(t.text, "JOINT")) {
        check_depth(open, t);
        open.push_back(begin_joint(t, open.back(), false));
      } else if (iequals(t.text, "End")) {
        check_depth(open, t);
        const Token site = tok_.expect("Site");
        open.push_back(begin_joint(site, open.back(), true));
      } else {
        tok_.fail(t, "JOINT, End Site or '}' in joint '" + motion_.joints[open.back()].name + "'");
      }
    }
  }

  /// Throws ParseError on `keyword`'s line if a joint opened inside `open` would be nested
  /// deeper than kMaxBvhDepth.
  void check_depth(const std::vector<int>& open, const Token& keyword) const {
    if (static_cast<int>(open.size()) < kMaxBvhDepth) return;
    tok_.fail(keyword.line,
              "joints nested at most " + std::to_string(kMaxBvhDepth) + " deep (kMaxBvhDepth)",
              "'" + std::string(keyword.text) + "' at depth " + std::to_string(open.size() + 1) +
                  ", inside '" + motion_.joints[open.back()].name + "'");
  }

  /// Reads a joint's name, '{', OFFSET and (not for end sites) CHANNELS; returns its index.
  /// `keyword` is ROOT, JOINT or the Site of End Site.
  int begin_joint(const Token& keyword, int parent, bool end_site) {
    BvhJoint j;
    j.parent = parent;
    j.end_site = end_site;
    // A name is the rest of the keyword's line (some exporters put spaces in names); an end site
    // is named after its parent (words after "End Site", which some files have, are ignored).
    std::string name;
    while (!tok_.peek().end() && tok_.peek().line == keyword.line && tok_.peek().text != "{") {
      if (!name.empty()) name += ' ';
      name += tok_.next().text;
    }
    if (end_site) {
      name = motion_.joints[parent].name + "_end";
    } else if (name.empty()) {
      const Token& t = tok_.peek();
      tok_.fail(keyword.line, "a joint name after " + std::string(keyword.text),
                !t.end() && t.line == keyword.line ? describe(t) : "end of line");
    } else {
      const std::string utf8 = to_utf8(name);
      motion_.transcoded_names += utf8 != name ? 1 : 0;
      name = utf8;
    }
    j.name = name;
    tok_.expect("{");
    tok_.expect("OFFSET");
    for (int a = 0; a < 3; ++a) j.offset[a] = number("OFFSET of joint '" + j.name + "'");
    j.first_channel = next_channel_;
    if (!end_site) parse_channels(&j);
    motion_.joints.push_back(std::move(j));
    return static_cast<int>(motion_.joints.size()) - 1;
  }

  void parse_channels(BvhJoint* j) {
    const Token keyword = tok_.expect("CHANNELS");
    const Token count = tok_.next();
    long long n = 0;
    if (!to_long(count.text, &n) || n < 0 || n > kMaxChannels) {
      tok_.fail(count, "a channel count from 0 to 6 for joint '" + j->name + "'");
    }
    for (long long k = 0; k < n; ++k) {
      const Token t = tok_.next();
      const BvhChannel c = channel(t, j->name);
      for (BvhChannel seen : j->channels) {
        if (seen == c) tok_.fail(t, "a channel not yet listed for joint '" + j->name + "'");
      }
      j->channels.push_back(c);
    }
    // One name too many on the CHANNELS line is a count that does not match the list.
    BvhChannel unused;
    if (tok_.peek().line == keyword.line && lookup_channel(tok_.peek().text, &unused)) {
      tok_.fail(tok_.peek(), "end of line after the " + std::to_string(n) +
                                 " channels of CHANNELS " + std::to_string(n) + " (joint '" +
                                 j->name + "')");
    }
    next_channel_ += static_cast<int>(n);
  }

  static bool lookup_channel(std::string_view text, BvhChannel* out) {
    for (const ChannelName& c : kChannelNames) {
      if (iequals(text, c.name)) {
        *out = c.channel;
        return true;
      }
    }
    return false;
  }

  BvhChannel channel(const Token& t, const std::string& joint) {
    BvhChannel c;
    if (!lookup_channel(t.text, &c)) tok_.fail(t, kChannelList + (" for joint '" + joint + "'"));
    return c;
  }

  double number(const std::string& what) {
    const Token t = tok_.next();
    double v = 0;
    if (!to_double(t.text, &v)) tok_.fail(t, "a number (" + what + ")");
    return v;
  }

  void parse_motion_header() {
    tok_.expect("Frames:");
    const Token count = tok_.next();
    long long n = 0;
    if (!to_long(count.text, &n) || n <= 0 || n > INT_MAX) {
      tok_.fail(count, "a positive whole number of frames after Frames:");
    }
    frames_ = static_cast<int>(n);
    tok_.expect("Frame");
    tok_.expect("Time:");
    const Token dt = tok_.next();
    if (!to_double(dt.text, &motion_.frame_time_s) || motion_.frame_time_s <= 0) {
      tok_.fail(dt, "a positive frame time in seconds after Frame Time:");
    }
    if (!tok_.peek().end() && tok_.peek().line == dt.line) {
      tok_.fail(tok_.peek(), "end of line after the frame time");
    }
  }

  /// Frames are lines: each holds exactly channel_count() values. BVH writers (Blender's,
  /// bvh11's, this one) put one frame per line, and reading by line reports a short or long
  /// frame on its own line instead of as a misalignment frames later. Blank lines are skipped.
  void parse_frames() {
    const int channels = next_channel_;
    if (channels == 0) {
      // Frames of a hierarchy without channels hold no values: nothing may follow.
      if (!tok_.peek().end()) {
        tok_.fail(tok_.peek(), "end of file (the hierarchy has no channels, so frames are empty)");
      }
      motion_.values.resize(frames_, 0);
      return;
    }
    // Reserve no more than the text can hold (a value and a separator take >= 2 bytes): a
    // "Frames:" line is not trusted with the allocation size.
    std::vector<double> values;
    values.reserve(std::min(static_cast<std::size_t>(channels) * static_cast<std::size_t>(frames_),
                            text_size_ / 2 + 1));
    std::vector<Token> line;
    for (int f = 0; f < frames_; ++f) {
      const auto frame = [&] {
        return "frame " + std::to_string(f + 1) + " of " + std::to_string(frames_) +
               ", one frame per line";
      };
      if (tok_.peek().end()) {
        tok_.fail(tok_.peek().line, std::to_string(frames_) + " frames (from Frames:)",
                  "end of file after " + std::to_string(f) + (f == 1 ? " frame" : " frames"));
      }
      line.clear();
      const long line_number = tok_.peek().line;
      while (!tok_.peek().end() && tok_.peek().line == line_number) line.push_back(tok_.next());
      if (static_cast<int>(line.size()) != channels) {
        tok_.fail(line_number, std::to_string(channels) + " values (" + frame() + ")",
                  std::to_string(line.size()) + " values");
      }
      for (int c = 0; c < channels; ++c) {
        double v = 0;
        if (!to_double(line[c].text, &v)) {
          tok_.fail(line[c], "a number (" + frame() + ", value " + std::to_string(c + 1) + ": " +
                                 describe_channel(c) + ")");
        }
        values.push_back(v);
      }
    }
    if (!tok_.peek().end()) {
      tok_.fail(tok_.peek(), "end of file after the " + std::to_string(frames_) + " frames");
    }
    motion_.values =
        Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
            values.data(), frames_, channels);
  }

  /// "<joint> <channel>" for value c of a frame.
  std::string describe_channel(int c) const {
    for (const BvhJoint& j : motion_.joints) {
      const int k = c - j.first_channel;
      if (k >= 0 && k < static_cast<int>(j.channels.size())) {
        return j.name + " " + to_string(j.channels[k]);
      }
    }
    return "?";
  }

  Tokenizer tok_;
  std::size_t text_size_;
  BvhMotion motion_;
  int next_channel_ = 0;  // channels listed so far
  int frames_ = 0;        // from "Frames:"
};

// ---------------------------------------------------------------------------------------------
// Checks of hand-built motions (parse_bvh only makes valid ones).

[[noreturn]] void invalid(const std::string& what) {
  throw sim::InvalidArgument("BVH motion: " + what);
}

/// The invariants forward kinematics and the writer rely on: parents before children, end sites
/// are leaves without channels, channels tile the value columns in joint order.
void check_structure(const BvhMotion& m) {
  int next = 0;
  for (std::size_t i = 0; i < m.joints.size(); ++i) {
    const BvhJoint& j = m.joints[i];
    const std::string name = "joint " + std::to_string(i) + " '" + j.name + "'";
    if (j.parent < -1 || j.parent >= static_cast<int>(i)) {
      invalid(name + ": parent must be -1 or an earlier joint, got " + std::to_string(j.parent));
    }
    if (j.parent >= 0 && m.joints[j.parent].end_site) invalid(name + ": parent is an end site");
    if (j.end_site && !j.channels.empty()) invalid(name + ": an end site has no channels");
    if (!j.channels.empty() && j.first_channel != next) {
      invalid(name + ": first_channel must be " + std::to_string(next) + ", got " +
              std::to_string(j.first_channel));
    }
    next += static_cast<int>(j.channels.size());
  }
  if (m.channel_count() != next) {
    invalid("values has " + std::to_string(m.channel_count()) + " columns, the joints list " +
            std::to_string(next) + " channels");
  }
}

void check_frame(const BvhMotion& m, int f) {
  if (f < 0 || f >= m.frame_count()) {
    invalid("frame " + std::to_string(f) + " out of range [0, " + std::to_string(m.frame_count()) +
            ")");
  }
}

Eigen::Matrix3d rotation_unchecked(const BvhMotion& m, int j, int f) {
  const BvhJoint& joint = m.joints[j];
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  for (std::size_t k = 0; k < joint.channels.size(); ++k) {
    const BvhChannel c = joint.channels[k];
    if (is_position(c)) continue;
    const double angle = m.values(f, joint.first_channel + static_cast<int>(k)) * kRadPerDeg;
    // Intrinsic: each later rotation is about the axes already turned by the earlier ones.
    r = r * Eigen::AngleAxisd(angle, Eigen::Vector3d::Unit(axis_of(c))).toRotationMatrix();
  }
  return r;
}

/// The joint's origin in its parent's frame (file units): the OFFSET, with each axis that has a
/// position channel replaced by the channel's value (see forward_kinematics in bvh.h).
Eigen::Vector3d translation_unchecked(const BvhMotion& m, int j, int f) {
  const BvhJoint& joint = m.joints[j];
  Eigen::Vector3d t = joint.offset;
  for (std::size_t k = 0; k < joint.channels.size(); ++k) {
    const BvhChannel c = joint.channels[k];
    if (is_position(c)) t[axis_of(c)] = m.values(f, joint.first_channel + static_cast<int>(k));
  }
  return t;
}

// ---------------------------------------------------------------------------------------------
// Writer.

/// `v` to `precision` significant digits, locale-independent ("%g" style).
std::string format_significant(double v, int precision) {
  char buffer[64];
  const auto [ptr, ec] =
      std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::general, precision);
  return ec == std::errc() ? std::string(buffer, ptr) : std::string("nan");
}

/// Names are written as the rest of a ROOT/JOINT line and read back the same way.
void check_name(const BvhJoint& j, std::size_t i) {
  if (j.end_site) return;  // written as "End Site", read back as "<parent>_end"
  bool blank = true;
  for (char c : j.name) {
    if (c == '\n' || c == '\r' || c == '{' || c == '}') {
      invalid("joint " + std::to_string(i) + ": a name cannot hold a line break or a brace");
    }
    if (!is_space(c)) blank = false;
  }
  if (blank) invalid("joint " + std::to_string(i) + ": empty name");
}

void check_writable(const BvhMotion& m, int precision) {
  if (precision < 1 || precision > 17) {
    invalid("precision must be 1-17 significant digits, got " + std::to_string(precision));
  }
  check_structure(m);
  if (m.joints.empty()) invalid("no joints");
  if (m.frame_count() < 1) invalid("no frames (a BVH file has at least one)");
  if (!(m.frame_time_s > 0) || !std::isfinite(m.frame_time_s)) {
    invalid("frame_time_s must be > 0, got " + format_significant(m.frame_time_s, 17));
  }
  std::vector<int> depth(m.joints.size(), 1);  // parents come first (check_structure)
  for (std::size_t i = 0; i < m.joints.size(); ++i) {
    check_name(m.joints[i], i);
    if (m.joints[i].parent >= 0) depth[i] = depth[m.joints[i].parent] + 1;
    if (depth[i] > kMaxBvhDepth) {
      invalid("joint " + std::to_string(i) + " '" + m.joints[i].name + "' is nested " +
              std::to_string(depth[i]) + " deep, more than kMaxBvhDepth (" +
              std::to_string(kMaxBvhDepth) + ")");
    }
    if (m.joints[i].end_site && m.joints[i].parent < 0) {
      invalid("joint " + std::to_string(i) + ": an end site needs a parent");
    }
    if (!m.joints[i].offset.allFinite())
      invalid("joint " + std::to_string(i) + ": offset not finite");
  }
  for (int f = 0; f < m.frame_count(); ++f) {
    for (int c = 0; c < m.channel_count(); ++c) {
      if (!std::isfinite(m.values(f, c))) {
        invalid("value at frame " + std::to_string(f) + ", channel " + std::to_string(c) +
                " is not finite");
      }
    }
  }
}

}  // namespace

const char* to_string(BvhChannel channel) {
  for (const ChannelName& c : kChannelNames) {
    if (c.channel == channel) return c.name;
  }
  return "?";
}

int BvhMotion::find(const std::string& name) const {
  for (std::size_t i = 0; i < joints.size(); ++i) {
    if (joints[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

BvhMotion parse_bvh(const std::string& text, const std::string& source) {
  return Parser(text, source).parse();
}

BvhMotion read_bvh(const std::string& path) { return parse_bvh(sim::read_file(path), path); }

std::string format_bvh(const BvhMotion& motion, int precision) {
  check_writable(motion, precision);
  const auto num = [precision](double v) { return format_significant(v, precision); };
  std::string out = "HIERARCHY\n";
  std::vector<int> open;  // joints written but not yet closed, outermost first
  const auto indent = [&out](std::size_t depth) { out.append(depth, '\t'); };
  const auto close = [&]() {
    open.pop_back();
    indent(open.size());
    out += "}\n";
  };
  for (std::size_t i = 0; i < motion.joints.size(); ++i) {
    const BvhJoint& j = motion.joints[i];
    // Close the joints that are not this one's ancestors: the file lists a joint's subtree
    // right after it, so only depth-first order can be written back in the same order.
    while (!open.empty() && open.back() != j.parent) close();
    if (open.empty() && j.parent != -1) {
      invalid("joint " + std::to_string(i) + " '" + j.name +
              "': joints must be in depth-first file order (each right after its parent's "
              "subtree so far)");
    }
    indent(open.size());
    out += j.end_site ? "End Site" : (j.parent < 0 ? "ROOT " : "JOINT ") + j.name;
    out += '\n';
    indent(open.size());
    out += "{\n";
    indent(open.size() + 1);
    out += "OFFSET " + num(j.offset.x()) + " " + num(j.offset.y()) + " " + num(j.offset.z()) + "\n";
    if (!j.end_site) {
      indent(open.size() + 1);
      out += "CHANNELS " + std::to_string(j.channels.size());
      for (BvhChannel c : j.channels) out += std::string(" ") + to_string(c);
      out += '\n';
    }
    open.push_back(static_cast<int>(i));
  }
  while (!open.empty()) close();
  out += "MOTION\nFrames: " + std::to_string(motion.frame_count()) +
         "\nFrame Time: " + num(motion.frame_time_s) + "\n";
  for (int f = 0; f < motion.frame_count(); ++f) {
    for (int c = 0; c < motion.channel_count(); ++c) {
      if (c > 0) out += ' ';
      out += num(motion.values(f, c));
    }
    out += '\n';
  }
  return out;
}

void write_bvh(const std::string& path, const BvhMotion& motion, int precision) {
  // format_bvh throws before the disk is touched; the write is whole or nothing.
  sim::write_file_atomically(path, format_bvh(motion, precision));
}

Eigen::Matrix3d local_rotation(const BvhMotion& motion, int j, int f) {
  if (j < 0 || j >= static_cast<int>(motion.joints.size())) {
    invalid("joint " + std::to_string(j) + " out of range [0, " +
            std::to_string(motion.joints.size()) + ")");
  }
  check_frame(motion, f);
  const BvhJoint& joint = motion.joints[j];
  if (joint.first_channel < 0 ||
      joint.first_channel + static_cast<int>(joint.channels.size()) > motion.channel_count()) {
    invalid("joint " + std::to_string(j) + " '" + joint.name + "': channels outside values");
  }
  return rotation_unchecked(motion, j, f);
}

BvhPose forward_kinematics(const BvhMotion& motion, int f, const BvhUnits& units) {
  check_structure(motion);
  check_frame(motion, f);
  if (!(units.metres_per_unit > 0) || !std::isfinite(units.metres_per_unit)) {
    invalid("metres_per_unit must be > 0, got " + format_significant(units.metres_per_unit, 17));
  }
  const std::size_t n = motion.joints.size();
  // Poses in the file's own frame and units first (F), mapped to the world (W) at the end.
  Eigen::Matrix3Xd p_F(3, n);
  std::vector<Eigen::Matrix3d> R_F(n);
  for (std::size_t i = 0; i < n; ++i) {
    const int j = static_cast<int>(i);
    const int parent = motion.joints[i].parent;
    const Eigen::Vector3d t = translation_unchecked(motion, j, f);
    const Eigen::Matrix3d r = rotation_unchecked(motion, j, f);
    if (parent < 0) {
      p_F.col(j) = t;
      R_F[i] = r;
    } else {
      p_F.col(j) = p_F.col(parent) + R_F[parent] * t;
      R_F[i] = R_F[parent] * r;
    }
  }
  const Eigen::Matrix3d R_WF = file_to_world(units.up);
  BvhPose pose;
  pose.positions_W = units.metres_per_unit * (R_WF * p_F);
  pose.rotations_W.resize(n);
  for (std::size_t i = 0; i < n; ++i) pose.rotations_W[i] = R_WF * R_F[i];
  return pose;
}

Eigen::Matrix3d file_to_world(UpAxis up) {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  if (up == UpAxis::kY) {
    // World (x, y, z) = file (z, x, y): forward +z becomes +x, up +y becomes +z.
    r << 0, 0, 1,  //
        1, 0, 0,   //
        0, 1, 0;
  }
  return r;
}

}  // namespace biodyn::mocap_io
