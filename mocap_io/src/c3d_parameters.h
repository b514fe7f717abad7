#pragma once
/// Private to mocap_io: the C3D parameter section, read and written (C3D User Guide, "The
/// Parameter Section", "Group Format", "Parameter Format", "Parameter Arrays").

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "c3d_binary.h"

namespace biodyn::mocap_io::c3d_internal {

/// The largest 16-bit unsigned word: the header's and the parameters' counts are at most this.
inline constexpr long kMaxWord = 65535;

/// Storage type of a parameter's values (the byte after the name and next-record offset).
enum class ParameterType : std::int8_t { kChar = -1, kByte = 1, kInt16 = 2, kFloat = 4 };

/// One parameter as stored. Arrays are in FORTRAN order: the first dimension varies fastest
/// (C3D User Guide, "Parameter Arrays").
struct Parameter {
  std::string group;  ///< upper case, e.g. "POINT"
  std::string name;   ///< upper case, e.g. "LABELS"
  ParameterType type = ParameterType::kInt16;
  std::vector<int> dimensions;  ///< empty for a scalar
  /// kByte (0..255), kInt16 (signed, as stored) and kFloat values; empty for kChar.
  std::vector<double> numbers;
  /// kChar values: one string per column of the first dimension (a 1-D array is one string),
  /// trailing blanks and NULs removed.
  std::vector<std::string> strings;
  std::size_t offset = 0;  ///< byte offset of the record in the file, for error messages

  /// "GROUP:NAME".
  std::string full_name() const { return group + ":" + name; }
  bool is_integer() const { return type == ParameterType::kByte || type == ParameterType::kInt16; }
  /// numbers[i] with a kInt16 word read as unsigned (0..65535), as the C3D User Guide asks of
  /// counts and pointers ("ANALOG:FORMAT": parameter integers are treated as unsigned).
  double unsigned_number(std::size_t i) const {
    const double v = numbers.at(i);
    return (type == ParameterType::kInt16 && v < 0) ? v + 65536.0 : v;
  }
};

/// The groups and parameters of a file.
class ParameterSection {
 public:
  /// The parameter GROUP:NAME (names are compared upper case), or nullptr.
  const Parameter* find(const std::string& group, const std::string& name) const;
  bool has_group(const std::string& group) const;

  std::vector<std::string>& groups() { return groups_; }
  std::vector<Parameter>& parameters() { return parameters_; }
  /// Byte offset just past the last record read (its description included).
  std::size_t records_end() const { return records_end_; }
  void set_records_end(std::size_t end) { records_end_ = end; }

 private:
  std::vector<std::string> groups_;
  std::vector<Parameter> parameters_;
  std::size_t records_end_ = 0;
};

/// `s` in upper case (C3D names are 7-bit ASCII).
std::string upper(std::string s);

/// `v` with up to 9 significant digits (a float parameter exactly), for messages.
std::string format_number(double v);

/// Throws ParseError(file, "byte <offset of p>", "<GROUP:NAME> " + expected, found).
[[noreturn]] void fail_parameter(const std::string& file, const Parameter& p,
                                 const std::string& expected, const std::string& found);

/// Value i of `p` as a count or index: an integer word read as unsigned (0..65535), a byte, or a
/// float holding a whole number. Throws ParseError (naming `what`, e.g. "point count") for a
/// missing, negative, fractional or non-finite value, or one above `max`.
long count_value(const std::string& file, const Parameter& p, const std::string& what,
                 std::size_t i = 0, long max = 2147483647L);

/// Parses the parameter section whose 4-byte header starts at `start`. `reader` must already be
/// narrowed to the section: a record that runs past it throws ParseError, as does an invalid
/// type, a negative or too large number of dimensions, a next-record offset pointing backwards
/// or outside the section. Walks the records in file order, so it always ends.
ParameterSection parse_parameters(const ByteReader& reader, std::size_t start);

/// Builds a parameter section for write_c3d: groups, each followed by its parameters. Throws
/// sim::InvalidArgument for values the format cannot hold (a dimension above 255, a record
/// longer than 32767 bytes, an integer outside -32768..65535, more than 255 blocks).
class ParameterWriter {
 public:
  /// Starts a group; parameters added next belong to it.
  void group(const std::string& name);
  /// 16-bit integers (values above 32767 are stored as unsigned words). `dimensions` empty for
  /// a scalar.
  void integers(const std::string& name, const std::vector<long>& values,
                const std::vector<int>& dimensions = {});
  void floats(const std::string& name, const std::vector<double>& values,
              const std::vector<int>& dimensions = {});
  /// One string: a 1-D char array.
  void text(const std::string& name, const std::string& value);
  /// Strings blank-padded to `width`: a (width, count) char array.
  void texts(const std::string& name, const std::vector<std::string>& values, int width);

  /// The whole section: its 4-byte header (with `format`'s processor byte), the records, the
  /// last with next-record offset 0, zero-padded to whole blocks.
  std::vector<std::uint8_t> serialize(const NumberFormat& format) const;

 private:
  struct Record {
    int group_id = 0;  ///< > 0: the group's id; the record is a parameter of it
    bool is_group = false;
    std::string name;
    Parameter value;  ///< type, dimensions, numbers; strings concatenated in `chars`
    std::string chars;
  };
  void add(const std::string& name, Parameter value, std::string chars);

  std::vector<Record> records_;
  int group_count_ = 0;
};

}  // namespace biodyn::mocap_io::c3d_internal
