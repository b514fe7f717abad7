#include "c3d_binary.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "biodyn/mocap_io/errors.h"
#include "biodyn/sim/errors.h"

namespace biodyn::mocap_io::c3d_internal {
namespace {

// VAX F_floating (DEC processor type), as two little-endian 16-bit words: the first holds the
// sign (bit 15), an 8-bit exponent biased by 128 (bits 14-7) and the top 7 fraction bits; the
// second the low 16 fraction bits. value = 0.1f (binary, hidden bit) * 2^(exponent - 128), i.e.
// (2^23 + fraction) * 2^(exponent - 152): the same bits read as IEEE are 4 times larger.
constexpr int kVaxExponentBias = 128;
constexpr int kVaxFractionBits = 23;
constexpr int kVaxMaxExponent = 255;

double decode_vax(std::uint16_t high, std::uint16_t low) {
  const bool negative = (high & 0x8000u) != 0;
  const int exponent = (high >> 7) & 0xFF;
  const std::uint32_t fraction = (static_cast<std::uint32_t>(high & 0x7Fu) << 16) | low;
  if (exponent == 0) {
    // Zero, or with the sign set a "reserved operand" (a fault on a VAX): no number.
    return negative ? -std::numeric_limits<double>::quiet_NaN() : 0.0;
  }
  const double magnitude = std::ldexp(static_cast<double>((1u << kVaxFractionBits) | fraction),
                                      exponent - kVaxExponentBias - kVaxFractionBits - 1);
  return negative ? -magnitude : magnitude;
}

void encode_vax(float value, std::uint16_t* high, std::uint16_t* low) {
  *high = 0;
  *low = 0;
  if (value == 0.0f) return;
  int exponent2 = 0;
  const double mantissa = std::frexp(std::fabs(static_cast<double>(value)), &exponent2);  // [.5,1)
  const int exponent = exponent2 + kVaxExponentBias;
  if (exponent > kVaxMaxExponent) {
    throw sim::InvalidArgument("C3D writer: " + std::to_string(value) +
                               " is too large for a DEC (VAX F_floating) float (max 2^127)");
  }
  if (exponent < 1) return;  // below the smallest VAX float (2^-128): stored as 0
  const auto fraction = static_cast<std::uint32_t>(
      std::ldexp(mantissa - 0.5, kVaxFractionBits + 1));  // 23 bits, exact for a float
  *high = static_cast<std::uint16_t>(
      (value < 0 ? 0x8000u : 0u) | (static_cast<std::uint32_t>(exponent) << 7) | (fraction >> 16));
  *low = static_cast<std::uint16_t>(fraction & 0xFFFFu);
}

std::uint16_t little16(const std::uint8_t* b) {
  return static_cast<std::uint16_t>(b[0] | (b[1] << 8));
}

void put_little16(std::uint16_t v, std::uint8_t* b) {
  b[0] = static_cast<std::uint8_t>(v & 0xFFu);
  b[1] = static_cast<std::uint8_t>(v >> 8);
}

}  // namespace

std::uint16_t NumberFormat::uint16(const std::uint8_t* b) const {
  return big_endian() ? static_cast<std::uint16_t>((b[0] << 8) | b[1]) : little16(b);
}

double NumberFormat::float32(const std::uint8_t* b) const {
  if (processor_ == C3dProcessor::kDec) return decode_vax(little16(b), little16(b + 2));
  std::uint32_t bits = 0;
  for (int i = 0; i < 4; ++i) {
    const int shift = big_endian() ? 8 * (3 - i) : 8 * i;
    bits |= static_cast<std::uint32_t>(b[i]) << shift;
  }
  float value = 0.0f;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}

void NumberFormat::put_uint16(std::uint16_t value, std::uint8_t* b) const {
  if (big_endian()) {
    b[0] = static_cast<std::uint8_t>(value >> 8);
    b[1] = static_cast<std::uint8_t>(value & 0xFFu);
  } else {
    put_little16(value, b);
  }
}

void NumberFormat::put_float32(double value, std::uint8_t* b) const {
  const auto f = static_cast<float>(value);
  if (processor_ == C3dProcessor::kDec) {
    if (!std::isfinite(f)) {
      throw sim::InvalidArgument("C3D writer: " + std::to_string(value) +
                                 " cannot be stored as a DEC float (no infinity or NaN)");
    }
    std::uint16_t high = 0, low = 0;
    encode_vax(f, &high, &low);
    put_little16(high, b);
    put_little16(low, b + 2);
    return;
  }
  std::uint32_t bits = 0;
  std::memcpy(&bits, &f, sizeof bits);
  for (int i = 0; i < 4; ++i) {
    const int shift = big_endian() ? 8 * (3 - i) : 8 * i;
    b[i] = static_cast<std::uint8_t>((bits >> shift) & 0xFFu);
  }
}

ByteReader::ByteReader(const std::vector<std::uint8_t>& bytes, std::string file,
                       NumberFormat format)
    : bytes_(&bytes), file_(std::move(file)), format_(format), end_(bytes.size()) {}

ByteReader ByteReader::narrowed(std::size_t end, std::string range) const {
  ByteReader r = *this;
  r.end_ = std::min(end, end_);
  r.range_ = std::move(range);
  return r;
}

const std::uint8_t* ByteReader::span(std::size_t offset, std::size_t count,
                                     const std::string& what) const {
  if (offset > end_ || count > end_ - offset) {
    fail(offset, what + " (" + std::to_string(count) + " bytes)",
         range_ + " at byte " + std::to_string(end_));
  }
  return bytes_->data() + offset;
}

std::string ByteReader::chars(std::size_t offset, std::size_t count,
                              const std::string& what) const {
  const std::uint8_t* p = span(offset, count, what);
  return std::string(reinterpret_cast<const char*>(p), count);
}

void ByteReader::fail(std::size_t offset, const std::string& expected,
                      const std::string& found) const {
  throw ParseError(file_, ParseError::byte(static_cast<long>(offset)), expected, found);
}

void ByteWriter::uint16(std::uint16_t value) {
  bytes_.resize(bytes_.size() + 2);
  format_.put_uint16(value, bytes_.data() + bytes_.size() - 2);
}

void ByteWriter::float32(double value) {
  bytes_.resize(bytes_.size() + 4);
  format_.put_float32(value, bytes_.data() + bytes_.size() - 4);
}

void ByteWriter::pad_to_block() {
  const std::size_t rest = bytes_.size() % kBlockBytes;
  if (rest != 0) bytes_.resize(bytes_.size() + kBlockBytes - rest, 0);
}

}  // namespace biodyn::mocap_io::c3d_internal
