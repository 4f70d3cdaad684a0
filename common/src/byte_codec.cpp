#include "common/byte_codec.hpp"

#include <algorithm>
#include <bit>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace alc::common {

// ---------------------------------------------------------------------------------------------
void ByteWriter::little_endian(std::uint64_t value, int byte_count) {
  for (int b = 0; b < byte_count; ++b) bytes_.push_back(static_cast<char>((value >> (8 * b)) & 0xffU));
}

void ByteWriter::u8(std::uint8_t value) { little_endian(value, 1); }
void ByteWriter::boolean(bool value) { little_endian(value ? 1U : 0U, 1); }
void ByteWriter::i32(std::int32_t value) { little_endian(std::bit_cast<std::uint32_t>(value), 4); }
void ByteWriter::u32(std::uint32_t value) { little_endian(value, 4); }
void ByteWriter::i64(std::int64_t value) { little_endian(std::bit_cast<std::uint64_t>(value), 8); }
void ByteWriter::u64(std::uint64_t value) { little_endian(value, 8); }
void ByteWriter::f64(double value) { little_endian(std::bit_cast<std::uint64_t>(value), 8); }

void ByteWriter::string(std::string_view value) {
  u64(value.size());
  bytes_.append(value);
}

void ByteWriter::f64_vector(const std::vector<double>& values) {
  u64(values.size());
  for (const double v : values) f64(v);
}

void ByteWriter::vector(const Eigen::VectorXd& values) {
  u64(static_cast<std::uint64_t>(values.size()));
  for (Eigen::Index i = 0; i < values.size(); ++i) f64(values[i]);
}

void ByteWriter::matrix(const Eigen::MatrixXd& values) {
  u64(static_cast<std::uint64_t>(values.rows()));
  u64(static_cast<std::uint64_t>(values.cols()));
  for (Eigen::Index c = 0; c < values.cols(); ++c)
    for (Eigen::Index r = 0; r < values.rows(); ++r) f64(values(r, c));
}

void ByteWriter::strings(const std::vector<std::string>& values) {
  u64(values.size());
  for (const auto& s : values) string(s);
}

void ByteWriter::write_header(std::string_view format, std::uint32_t version) {
  string(format);
  u32(version);
}

// ---------------------------------------------------------------------------------------------
ByteReader::ByteReader(std::string_view bytes, std::string what) : bytes_(bytes), what_(std::move(what)) {}

void ByteReader::fail(const std::string& why) const { throw std::runtime_error(what_ + ": " + why); }

std::uint64_t ByteReader::little_endian(int byte_count, std::string_view field) {
  const auto need = static_cast<std::size_t>(byte_count);
  if (remaining() < need)
    fail("truncated: " + std::string(field) + " at byte " + std::to_string(position_) + " needs " +
         std::to_string(need) + " bytes, " + std::to_string(remaining()) + " left");
  std::uint64_t value = 0;
  for (std::size_t b = 0; b < need; ++b)
    value |= std::uint64_t{static_cast<unsigned char>(bytes_[position_ + b])} << (8 * b);
  position_ += need;
  return value;
}

std::uint8_t ByteReader::u8(std::string_view field) { return static_cast<std::uint8_t>(little_endian(1, field)); }

bool ByteReader::boolean(std::string_view field) {
  const std::size_t at = position_;
  const auto value = little_endian(1, field);
  if (value > 1)
    fail("corrupt: " + std::string(field) + " at byte " + std::to_string(at) + " is " + std::to_string(value) +
         ", not a bool (0 or 1)");
  return value == 1;
}

std::int32_t ByteReader::i32(std::string_view field) {
  return std::bit_cast<std::int32_t>(static_cast<std::uint32_t>(little_endian(4, field)));
}
std::uint32_t ByteReader::u32(std::string_view field) { return static_cast<std::uint32_t>(little_endian(4, field)); }
std::int64_t ByteReader::i64(std::string_view field) { return std::bit_cast<std::int64_t>(little_endian(8, field)); }
std::uint64_t ByteReader::u64(std::string_view field) { return little_endian(8, field); }
double ByteReader::f64(std::string_view field) { return std::bit_cast<double>(little_endian(8, field)); }

std::size_t ByteReader::count(std::size_t element_size, std::string_view field) {
  const std::size_t at = position_;
  const std::uint64_t n = little_endian(8, field);
  // Every element takes at least `element_size` bytes: a count beyond the bytes left is corrupt,
  // caught before anything is allocated for it.
  if (n > remaining() / element_size)
    fail("corrupt: " + std::string(field) + " at byte " + std::to_string(at) + " claims " + std::to_string(n) +
         " element(s) of at least " + std::to_string(element_size) + " byte(s), but only " +
         std::to_string(remaining()) + " bytes are left");
  return static_cast<std::size_t>(n);
}

std::string ByteReader::string(std::string_view field) {
  const std::size_t n = count(1, field);
  std::string value(bytes_.substr(position_, n));
  position_ += n;
  return value;
}

std::vector<double> ByteReader::f64_vector(std::string_view field) {
  std::vector<double> values(count(8, field));
  for (double& v : values) v = f64(field);
  return values;
}

Eigen::VectorXd ByteReader::vector(std::string_view field) {
  Eigen::VectorXd values(static_cast<Eigen::Index>(count(8, field)));
  for (Eigen::Index i = 0; i < values.size(); ++i) values[i] = f64(field);
  return values;
}

Eigen::MatrixXd ByteReader::matrix(std::string_view field) {
  const std::size_t at = position_;
  const std::uint64_t rows = u64(field);
  const std::uint64_t cols = u64(field);
  // An empty matrix holds no bytes to vouch for its other dimension: that one is bounded instead
  // (a 0 x 2^62 matrix would take ages to walk; found by fuzz/run_state_fuzz.cpp).
  constexpr std::uint64_t kMaxEmptyDimension = std::uint64_t{1} << 20;
  const bool fits = (rows == 0 || cols == 0) ? std::max(rows, cols) <= kMaxEmptyDimension
                                             : cols <= remaining() / 8 / rows;
  if (!fits || rows > static_cast<std::uint64_t>(std::numeric_limits<Eigen::Index>::max()) ||
      cols > static_cast<std::uint64_t>(std::numeric_limits<Eigen::Index>::max()))
    fail("corrupt: " + std::string(field) + " at byte " + std::to_string(at) + " claims " + std::to_string(rows) +
         " x " + std::to_string(cols) + " values, but only " + std::to_string(remaining()) + " bytes are left");
  Eigen::MatrixXd values(static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(cols));
  for (Eigen::Index c = 0; c < values.cols(); ++c)
    for (Eigen::Index r = 0; r < values.rows(); ++r) values(r, c) = f64(field);
  return values;
}

std::vector<std::string> ByteReader::strings(std::string_view field) {
  // Each string takes at least its 8-byte length.
  std::vector<std::string> values(count(8, field));
  for (auto& s : values) s = string(field);
  return values;
}

std::uint32_t ByteReader::read_header(std::string_view format) {
  const auto foreign = [&](const std::string& why) { fail("not a '" + std::string(format) + "' payload: " + why); };
  if (remaining() < 8) foreign("too short for a header");
  const std::uint64_t n = little_endian(8, "format name");
  if (n != format.size() || remaining() < n || bytes_.substr(position_, n) != format) foreign("foreign format");
  position_ += format.size();
  if (remaining() < 4) foreign("truncated: no version after the format name");
  return u32("format version");
}

void ByteReader::expect_done() const {
  if (!done())
    fail("corrupt: " + std::to_string(remaining()) + " byte(s) left over after byte " + std::to_string(position_));
}

// ---------------------------------------------------------------------------------------------
std::uint64_t checksum64(std::string_view bytes) {
  std::uint64_t hash = 0xcbf29ce484222325ULL;  // FNV-1a 64 offset basis
  for (const char c : bytes) {
    hash ^= static_cast<unsigned char>(c);
    hash *= 0x100000001b3ULL;  // FNV-1a 64 prime
  }
  return hash;
}

std::string checksum64_hex(std::string_view bytes) {
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(checksum64(bytes)));
  return hex;
}

}  // namespace alc::common
