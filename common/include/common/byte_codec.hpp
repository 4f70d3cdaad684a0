#pragma once
// One binary format for values that a file or a database blob keeps, the same on every host:
// little-endian whatever the host's byte order (each value goes through std::bit_cast to an
// unsigned integer and byte shifts), doubles as their IEEE 754 bits (NaN payloads, -0.0, infinities
// and denormals come back bit for bit).
//
// The layout, field by field, with no padding and no alignment:
//   u8, bool        1 byte (bool: 0 or 1; anything else is corrupt)
//   i32, u32        4 bytes, little-endian, two's complement for i32
//   i64, u64        8 bytes, little-endian, two's complement for i64
//   f64             8 bytes: the little-endian u64 of the double's bits
//   string          u64 byte count, then the bytes (no terminator, any content)
//   f64 vector      u64 count, then count f64
//   VectorXd        u64 size, then size f64
//   MatrixXd        u64 rows, u64 cols, then rows*cols f64 in column-major order (column 0 top to
//                   bottom, then column 1, ...: Eigen's default storage order)
//   string vector   u64 count, then count strings
//   header          string format name, then u32 version (write_header / read_header)
//
// ByteReader throws std::runtime_error naming the field and the byte offset when the payload ends
// too early or a length cannot be right (more elements than bytes left).
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace alc::common {

class ByteWriter {
 public:
  void u8(std::uint8_t value);
  void boolean(bool value);
  void i32(std::int32_t value);
  void u32(std::uint32_t value);
  void i64(std::int64_t value);
  void u64(std::uint64_t value);
  void f64(double value);
  void string(std::string_view value);
  void f64_vector(const std::vector<double>& values);
  void vector(const Eigen::VectorXd& values);
  void matrix(const Eigen::MatrixXd& values);  // column-major
  void strings(const std::vector<std::string>& values);
  // The format name and version that open a payload, so a reader refuses another program's bytes.
  void write_header(std::string_view format, std::uint32_t version);

  const std::string& bytes() const { return bytes_; }
  std::string take() { return std::move(bytes_); }

 private:
  void little_endian(std::uint64_t value, int byte_count);
  std::string bytes_;
};

class ByteReader {
 public:
  // `what` names the payload in error messages ("replay history snapshot", say). The reader keeps a
  // view: `bytes` must outlive it.
  explicit ByteReader(std::string_view bytes, std::string what = "payload");

  // Each read takes the name of the field for the error message.
  std::uint8_t u8(std::string_view field = "u8");
  bool boolean(std::string_view field = "bool");
  std::int32_t i32(std::string_view field = "i32");
  std::uint32_t u32(std::string_view field = "u32");
  std::int64_t i64(std::string_view field = "i64");
  std::uint64_t u64(std::string_view field = "u64");
  double f64(std::string_view field = "f64");
  std::string string(std::string_view field = "string");
  std::vector<double> f64_vector(std::string_view field = "f64 vector");
  Eigen::VectorXd vector(std::string_view field = "vector");
  Eigen::MatrixXd matrix(std::string_view field = "matrix");
  std::vector<std::string> strings(std::string_view field = "string vector");
  // Returns the version; throws std::runtime_error when the payload is not of `format`.
  std::uint32_t read_header(std::string_view format);

  bool done() const { return position_ == bytes_.size(); }
  std::size_t remaining() const { return bytes_.size() - position_; }
  std::size_t position() const { return position_; }
  // Throws std::runtime_error when bytes are left over (a payload longer than its fields).
  void expect_done() const;

 private:
  std::uint64_t little_endian(int byte_count, std::string_view field);
  // A count of elements of `element_size` bytes each that must fit in the bytes left.
  std::size_t count(std::size_t element_size, std::string_view field);
  [[noreturn]] void fail(const std::string& why) const;

  std::string_view bytes_;
  std::string what_;
  std::size_t position_ = 0;
};

// FNV-1a, 64 bit, of `bytes`: a checksum that tells a damaged payload from a sound one (not a
// cryptographic hash). checksum64("") == 0xcbf29ce484222325.
std::uint64_t checksum64(std::string_view bytes);

// checksum64(bytes) as 16 lower-case hex digits: the content hash of a recording or a machine file
// as a run's identity stores it.
std::string checksum64_hex(std::string_view bytes);

}  // namespace alc::common
