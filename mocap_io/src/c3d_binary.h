#pragma once
/// Private to mocap_io: the number encodings of the three C3D processor types and bounds-checked
/// access to a file held in memory (C3D User Guide, "DEC, Intel, and SGI/MIPS").

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "biodyn/mocap_io/c3d.h"

namespace biodyn::mocap_io::c3d_internal {

/// Bytes in one C3D block; every section starts on a block boundary (C3D User Guide, "The C3D
/// File Structure").
constexpr std::size_t kBlockBytes = 512;
/// Byte 2 of the file (and of the parameter section header): 0x50, the C3D signature (C3D User
/// Guide, "The Header Section").
constexpr std::uint8_t kC3dKey = 0x50;

/// How a processor type stores 16-bit integers and 32-bit floats (C3D User Guide, "DEC, Intel,
/// and SGI/MIPS"): Intel little-endian IEEE; DEC little-endian integers and VAX F_floating;
/// MIPS big-endian IEEE.
class NumberFormat {
 public:
  explicit NumberFormat(C3dProcessor processor) : processor_(processor) {}

  C3dProcessor processor() const { return processor_; }
  bool big_endian() const { return processor_ == C3dProcessor::kMips; }

  std::int16_t int16(const std::uint8_t* bytes) const {
    return static_cast<std::int16_t>(uint16(bytes));
  }
  std::uint16_t uint16(const std::uint8_t* bytes) const;
  /// The stored float, exactly, as a double. A DEC reserved operand (sign set, exponent 0) is a
  /// negative NaN.
  double float32(const std::uint8_t* bytes) const;

  void put_uint16(std::uint16_t value, std::uint8_t* bytes) const;
  void put_int16(std::int16_t value, std::uint8_t* bytes) const {
    put_uint16(static_cast<std::uint16_t>(value), bytes);
  }
  /// Stores `value` (rounded to float). Throws sim::InvalidArgument for a value the format
  /// cannot hold: DEC floats have no infinity or NaN and top out at 2^127.
  void put_float32(double value, std::uint8_t* bytes) const;

 private:
  C3dProcessor processor_;
};

/// Read-only, bounds-checked access to a whole file in memory. Reads take a byte offset from the
/// start of the file; a read that would run past the readable range throws ParseError naming
/// the offset, what was being read and where the range ends. A reader can be narrowed to a
/// section (the parameter section) so that nothing in it is read from outside it.
class ByteReader {
 public:
  ByteReader(const std::vector<std::uint8_t>& bytes, std::string file, NumberFormat format);

  /// A reader of the same bytes that may read only [0, end); `range` names the end in errors
  /// (e.g. "the end of the parameter section").
  ByteReader narrowed(std::size_t end, std::string range) const;

  const std::string& file() const { return file_; }
  const NumberFormat& format() const { return format_; }
  /// Bytes that may be read: [0, end()).
  std::size_t end() const { return end_; }

  /// Checks that [offset, offset + count) is readable and returns its first byte.
  const std::uint8_t* span(std::size_t offset, std::size_t count, const std::string& what) const;
  std::uint8_t byte(std::size_t offset, const std::string& what) const {
    return *span(offset, 1, what);
  }
  std::int8_t signed_byte(std::size_t offset, const std::string& what) const {
    return static_cast<std::int8_t>(byte(offset, what));
  }
  std::int16_t int16(std::size_t offset, const std::string& what) const {
    return format_.int16(span(offset, 2, what));
  }
  std::uint16_t uint16(std::size_t offset, const std::string& what) const {
    return format_.uint16(span(offset, 2, what));
  }
  double float32(std::size_t offset, const std::string& what) const {
    return format_.float32(span(offset, 4, what));
  }
  std::string chars(std::size_t offset, std::size_t count, const std::string& what) const;

  /// Throws ParseError(file, "byte <offset>", expected, found).
  [[noreturn]] void fail(std::size_t offset, const std::string& expected,
                         const std::string& found) const;

 private:
  const std::vector<std::uint8_t>* bytes_;
  std::string file_;
  NumberFormat format_;
  std::size_t end_;
  std::string range_ = "the end of the file";
};

/// Appends numbers to a growing byte buffer in a processor's format (the writer's side of
/// ByteReader).
class ByteWriter {
 public:
  explicit ByteWriter(NumberFormat format) : format_(format) {}

  const NumberFormat& format() const { return format_; }
  std::vector<std::uint8_t>& bytes() { return bytes_; }
  std::size_t size() const { return bytes_.size(); }

  void byte(std::uint8_t value) { bytes_.push_back(value); }
  void signed_byte(std::int8_t value) { bytes_.push_back(static_cast<std::uint8_t>(value)); }
  void uint16(std::uint16_t value);
  void int16(std::int16_t value) { uint16(static_cast<std::uint16_t>(value)); }
  void float32(double value);
  void chars(const std::string& text) { bytes_.insert(bytes_.end(), text.begin(), text.end()); }
  /// Pads with zeros to the next 512-byte block boundary.
  void pad_to_block();
  /// Overwrites the 16-bit word at `offset` (already written).
  void patch_uint16(std::size_t offset, std::uint16_t value) {
    format_.put_uint16(value, bytes_.data() + offset);
  }

 private:
  NumberFormat format_;
  std::vector<std::uint8_t> bytes_;
};

}  // namespace biodyn::mocap_io::c3d_internal
