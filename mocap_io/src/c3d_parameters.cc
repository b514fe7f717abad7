#include "c3d_parameters.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>

#include "biodyn/mocap_io/errors.h"
#include "biodyn/sim/errors.h"

namespace biodyn::mocap_io::c3d_internal {
namespace {

// C3D User Guide, "Parameter Arrays": an array has 1 to 7 dimensions, each stored in one byte.
constexpr int kMaxDimensions = 7;
constexpr int kMaxDimension = 255;
// The next-record offset is a signed 16-bit word.
constexpr std::size_t kMaxRecordBytes = 32767;
// The block count in the parameter section header is one byte.
constexpr std::size_t kMaxParameterBlocks = 255;

std::string trim_right(std::string s) {
  while (!s.empty() && (s.back() == ' ' || s.back() == '\0')) s.pop_back();
  return s;
}

std::string trim(std::string s) {
  s = trim_right(std::move(s));
  const std::size_t first = s.find_first_not_of(' ');
  return first == std::string::npos ? std::string() : s.substr(first);
}

/// Splits char data along its first dimension (C3D User Guide, "Parameter Arrays": a (n, m)
/// char array holds m strings of n characters).
std::vector<std::string> split_strings(const std::string& data, const std::vector<int>& dims) {
  if (dims.size() <= 1) return {trim(data)};
  const auto width = static_cast<std::size_t>(dims[0]);
  std::vector<std::string> out;
  if (width == 0) return out;
  for (std::size_t at = 0; at + width <= data.size(); at += width) {
    out.push_back(trim(data.substr(at, width)));
  }
  return out;
}

/// The values of one parameter record, from its type byte on. Returns the offset just past the
/// data.
std::size_t read_values(const ByteReader& r, std::size_t at, Parameter* p) {
  const std::string what = "parameter " + p->full_name();
  const std::int8_t type = r.signed_byte(at, what + " type");
  if (type != -1 && type != 1 && type != 2 && type != 4) {
    r.fail(at, what + " type -1 (char), 1 (byte), 2 (int16) or 4 (float)", std::to_string(type));
  }
  p->type = static_cast<ParameterType>(type);
  const std::int8_t dimension_count = r.signed_byte(at + 1, what + " dimension count");
  if (dimension_count < 0 || dimension_count > kMaxDimensions) {
    r.fail(at + 1, what + " dimension count 0.." + std::to_string(kMaxDimensions),
           std::to_string(dimension_count));
  }
  std::uint64_t count = 1;  // <= 255^7: no overflow
  for (int d = 0; d < dimension_count; ++d) {
    const int size = r.byte(at + 2 + static_cast<std::size_t>(d), what + " dimension");
    p->dimensions.push_back(size);
    count *= static_cast<std::uint64_t>(size);
  }
  const std::size_t data_at = at + 2 + static_cast<std::size_t>(dimension_count);
  const std::uint64_t element_bytes = static_cast<std::uint64_t>(type < 0 ? -type : type);
  const std::uint64_t data_bytes = count * element_bytes;
  if (data_at > r.end() || data_bytes > r.end() - data_at) {
    r.fail(data_at, what + " data (" + std::to_string(data_bytes) + " bytes)",
           "the end of the parameter section at byte " + std::to_string(r.end()));
  }
  const auto n = static_cast<std::size_t>(count);
  switch (p->type) {
    case ParameterType::kChar:
      p->strings = split_strings(r.chars(data_at, n, what), p->dimensions);
      break;
    case ParameterType::kByte:
      for (std::size_t i = 0; i < n; ++i) p->numbers.push_back(r.byte(data_at + i, what));
      break;
    case ParameterType::kInt16:
      for (std::size_t i = 0; i < n; ++i) p->numbers.push_back(r.int16(data_at + 2 * i, what));
      break;
    case ParameterType::kFloat:
      for (std::size_t i = 0; i < n; ++i) p->numbers.push_back(r.float32(data_at + 4 * i, what));
      break;
  }
  return data_at + static_cast<std::size_t>(data_bytes);
}

}  // namespace

std::string upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

std::string format_number(double v) {
  std::ostringstream s;
  s << std::setprecision(9) << v;
  return s.str();
}

void fail_parameter(const std::string& file, const Parameter& p, const std::string& expected,
                    const std::string& found) {
  throw ParseError(file, ParseError::byte(static_cast<long>(p.offset)),
                   p.full_name() + " " + expected, found);
}

long count_value(const std::string& file, const Parameter& p, const std::string& what,
                 std::size_t i, long max) {
  if (i >= p.numbers.size()) {
    fail_parameter(file, p, "with a value " + std::to_string(i + 1) + " (" + what + ")",
                   std::to_string(p.numbers.size()) + " numeric values");
  }
  const double v = p.unsigned_number(i);
  if (!(v >= 0) || v != std::floor(v) || v > static_cast<double>(max)) {
    fail_parameter(file, p, what + ": a whole number in 0.." + std::to_string(max),
                   format_number(p.numbers[i]));
  }
  return static_cast<long>(v);
}

const Parameter* ParameterSection::find(const std::string& group, const std::string& name) const {
  const std::string g = upper(group), n = upper(name);
  for (const Parameter& p : parameters_) {
    if (p.group == g && p.name == n) return &p;
  }
  return nullptr;
}

bool ParameterSection::has_group(const std::string& group) const {
  return std::find(groups_.begin(), groups_.end(), upper(group)) != groups_.end();
}

ParameterSection parse_parameters(const ByteReader& r, std::size_t start) {
  std::map<int, std::string> group_names;  // group id -> name
  std::vector<std::pair<int, Parameter>> parameters;
  std::size_t at = start + 4;  // past the section header (C3D User Guide, "Parameter header")
  std::size_t records_end = at;
  // Each record starts strictly after the previous one's offset word and inside the section:
  // the walk ends.
  while (at + 2 <= r.end()) {
    const std::size_t record = at;
    const std::int8_t name_length = r.signed_byte(at, "parameter record name length");
    if (name_length == 0) break;  // no more records
    const std::int8_t id = r.signed_byte(at + 1, "parameter record group id");
    if (id == 0) r.fail(at + 1, "a nonzero group id (group < 0, parameter > 0)", "0");
    // A negative name length marks a locked record (C3D User Guide, "Locked Parameters").
    const auto length = static_cast<std::size_t>(name_length < 0 ? -name_length : name_length);
    const std::string name = upper(r.chars(at + 2, length, "parameter record name"));
    const std::size_t offset_word = at + 2 + length;
    const std::int16_t next_offset = r.int16(offset_word, "offset to the next parameter record");
    std::size_t after = offset_word + 2;
    if (id < 0) {
      group_names.emplace(-id, name);
    } else {
      Parameter p;
      p.name = name;
      p.offset = record;
      // Groups normally precede their parameters; a later group is named at the end.
      const auto group = group_names.find(id);
      p.group = group != group_names.end() ? group->second : "group " + std::to_string(id);
      after = read_values(r, after, &p);
      parameters.emplace_back(id, std::move(p));
    }
    const std::uint8_t description_length = r.byte(after, "record description length");
    r.span(after + 1, description_length, "record description");
    records_end = std::max(records_end, after + 1 + description_length);
    if (next_offset == 0) break;  // the last record (C3D User Guide, "Group Format")
    if (next_offset < 0) {
      r.fail(offset_word, "a positive offset to the next parameter record",
             std::to_string(next_offset));
    }
    at = offset_word + static_cast<std::size_t>(next_offset);
    if (at > r.end()) {
      r.fail(offset_word,
             "a next parameter record inside the parameter section (ending at byte " +
                 std::to_string(r.end()) + ")",
             "one at byte " + std::to_string(at));
    }
  }
  ParameterSection section;
  section.set_records_end(records_end);
  for (const auto& [id, name] : group_names) section.groups().push_back(name);
  for (auto& [id, p] : parameters) {
    const auto it = group_names.find(id);
    if (it == group_names.end()) continue;  // a parameter of no group cannot be looked up
    p.group = it->second;
    section.parameters().push_back(std::move(p));
  }
  return section;
}

void ParameterWriter::group(const std::string& name) {
  Record g;
  g.is_group = true;
  g.group_id = ++group_count_;
  g.name = name;
  records_.push_back(std::move(g));
}

void ParameterWriter::add(const std::string& name, Parameter value, std::string chars) {
  if (value.dimensions.size() > static_cast<std::size_t>(kMaxDimensions)) {
    throw sim::InvalidArgument("C3D writer: parameter " + name + " has more than 7 dimensions");
  }
  for (int d : value.dimensions) {
    if (d < 0 || d > kMaxDimension) {
      throw sim::InvalidArgument("C3D writer: parameter " + name + " dimension " +
                                 std::to_string(d) + " outside 0..255");
    }
  }
  Record r;
  r.group_id = group_count_;
  r.name = name;
  r.value = std::move(value);
  r.chars = std::move(chars);
  records_.push_back(std::move(r));
}

void ParameterWriter::integers(const std::string& name, const std::vector<long>& values,
                               const std::vector<int>& dimensions) {
  Parameter p;
  p.type = ParameterType::kInt16;
  p.dimensions = dimensions;
  for (long v : values) {
    if (v < -32768 || v > 65535) {
      throw sim::InvalidArgument("C3D writer: parameter " + name + " value " + std::to_string(v) +
                                 " does not fit a 16-bit word");
    }
    p.numbers.push_back(static_cast<double>(v));
  }
  add(name, std::move(p), "");
}

void ParameterWriter::floats(const std::string& name, const std::vector<double>& values,
                             const std::vector<int>& dimensions) {
  Parameter p;
  p.type = ParameterType::kFloat;
  p.dimensions = dimensions;
  p.numbers = values;
  add(name, std::move(p), "");
}

void ParameterWriter::text(const std::string& name, const std::string& value) {
  Parameter p;
  p.type = ParameterType::kChar;
  p.dimensions = {static_cast<int>(value.size())};
  add(name, std::move(p), value);
}

void ParameterWriter::texts(const std::string& name, const std::vector<std::string>& values,
                            int width) {
  Parameter p;
  p.type = ParameterType::kChar;
  p.dimensions = {width, static_cast<int>(values.size())};
  std::string chars;
  for (const std::string& v : values) {
    chars += v.substr(0, static_cast<std::size_t>(width));
    chars.append(static_cast<std::size_t>(width) - std::min(v.size(), std::size_t(width)), ' ');
  }
  add(name, std::move(p), chars);
}

std::vector<std::uint8_t> ParameterWriter::serialize(const NumberFormat& format) const {
  ByteWriter w(format);
  // Section header (C3D User Guide, "Parameter header"): two ignored bytes, the block count
  // (patched below), the processor byte.
  w.byte(1);
  w.byte(kC3dKey);
  w.byte(0);
  w.byte(static_cast<std::uint8_t>(format.processor()));
  std::size_t previous_offset_word = 0;
  for (const Record& r : records_) {
    const std::size_t record_start = w.size();
    if (previous_offset_word != 0) {
      w.patch_uint16(previous_offset_word,
                     static_cast<std::uint16_t>(record_start - previous_offset_word));
    }
    w.signed_byte(static_cast<std::int8_t>(r.name.size()));
    w.signed_byte(static_cast<std::int8_t>(r.is_group ? -r.group_id : r.group_id));
    w.chars(r.name);
    previous_offset_word = w.size();
    w.uint16(0);  // offset to the next record; stays 0 for the last one
    if (!r.is_group) {
      const Parameter& p = r.value;
      w.signed_byte(static_cast<std::int8_t>(p.type));
      w.byte(static_cast<std::uint8_t>(p.dimensions.size()));
      for (int d : p.dimensions) w.byte(static_cast<std::uint8_t>(d));
      if (p.type == ParameterType::kChar) w.chars(r.chars);
      for (double v : p.numbers) {
        if (p.type == ParameterType::kFloat) {
          w.float32(v);
        } else {
          w.uint16(static_cast<std::uint16_t>(static_cast<long>(v) & 0xFFFF));
        }
      }
    }
    w.byte(0);  // no description
    if (w.size() - record_start > kMaxRecordBytes) {
      throw sim::InvalidArgument("C3D writer: parameter " + r.name + " needs " +
                                 std::to_string(w.size() - record_start) +
                                 " bytes, more than a record can hold (32767)");
    }
  }
  w.pad_to_block();
  const std::size_t blocks = w.size() / kBlockBytes;
  if (blocks > kMaxParameterBlocks) {
    throw sim::InvalidArgument("C3D writer: the parameters need " + std::to_string(blocks) +
                               " blocks, more than the 255 a C3D file can hold");
  }
  w.bytes()[2] = static_cast<std::uint8_t>(blocks);
  return std::move(w.bytes());
}

}  // namespace biodyn::mocap_io::c3d_internal
