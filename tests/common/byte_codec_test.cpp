#include <bit>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

#include "common/byte_codec.hpp"

using alc::common::ByteReader;
using alc::common::ByteWriter;
using Catch::Matchers::Contains;

namespace {

std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }

std::string hex(const std::string& bytes) {
  static const char* digits = "0123456789ABCDEF";
  std::string out;
  for (const char c : bytes) {
    const auto b = static_cast<unsigned char>(c);
    if (!out.empty()) out += ' ';
    out += digits[b >> 4];
    out += digits[b & 0xf];
  }
  return out;
}

}  // namespace

TEST_CASE("byte codec: the bytes are little-endian whatever the host") {
  ByteWriter w;
  w.f64(1.0);
  CHECK(hex(w.bytes()) == "00 00 00 00 00 00 F0 3F");
  ByteWriter ints;
  ints.i32(-2);
  ints.u32(0x01020304U);
  ints.u64(0x0102030405060708ULL);
  ints.boolean(true);
  ints.string("ab");
  CHECK(hex(ints.bytes()) ==
        "FE FF FF FF 04 03 02 01 08 07 06 05 04 03 02 01 01 02 00 00 00 00 00 00 00 61 62");
}

TEST_CASE("byte codec: doubles come back bit for bit (NaN payloads, -0, inf, denormals)") {
  const double values[] = {
      -0.0,
      0.0,
      std::numeric_limits<double>::infinity(),
      -std::numeric_limits<double>::infinity(),
      std::numeric_limits<double>::denorm_min(),
      -std::numeric_limits<double>::denorm_min() * 777,
      std::numeric_limits<double>::min(),
      std::numeric_limits<double>::max(),
      std::bit_cast<double>(0x7ff8000000000001ULL),  // quiet NaN with a payload
      std::bit_cast<double>(0xfff4000000abcdefULL),  // negative signalling-pattern NaN with a payload
      0.1,
  };
  ByteWriter w;
  for (const double v : values) w.f64(v);
  std::vector<double> many;
  std::mt19937_64 rng(97);
  for (int i = 0; i < 1000; ++i) many.push_back(std::bit_cast<double>(rng()));
  w.f64_vector(many);
  const std::string bytes = w.take();
  ByteReader r(bytes);
  for (const double v : values) CHECK(bits(r.f64()) == bits(v));
  const std::vector<double> back = r.f64_vector();
  REQUIRE(back.size() == many.size());
  for (std::size_t i = 0; i < many.size(); ++i) CHECK(bits(back[i]) == bits(many[i]));
  CHECK(r.done());
  r.expect_done();
}

TEST_CASE("byte codec: every kind of field round-trips, matrices column-major") {
  Eigen::MatrixXd m(2, 3);
  m << 1, 2, 3, 4, 5, 6;
  Eigen::VectorXd v(3);
  v << -1.5, std::numeric_limits<double>::quiet_NaN(), 2e-310;
  ByteWriter w;
  w.write_header("alc test", 7);
  w.u8(250);
  w.boolean(false);
  w.i32(std::numeric_limits<std::int32_t>::min());
  w.i64(-1234567890123LL);
  w.u64(std::numeric_limits<std::uint64_t>::max());
  w.string(std::string("with\0zero", 9));
  w.vector(v);
  w.matrix(m);
  w.matrix(Eigen::MatrixXd(0, 4));
  w.strings({"", "E_X0C", "T_ENV"});
  const std::string bytes = w.bytes();

  ByteReader r(bytes);
  CHECK(r.read_header("alc test") == 7);
  CHECK(r.u8() == 250);
  CHECK_FALSE(r.boolean());
  CHECK(r.i32() == std::numeric_limits<std::int32_t>::min());
  CHECK(r.i64() == -1234567890123LL);
  CHECK(r.u64() == std::numeric_limits<std::uint64_t>::max());
  CHECK(r.string() == std::string("with\0zero", 9));
  const Eigen::VectorXd v2 = r.vector();
  REQUIRE(v2.size() == 3);
  CHECK(v2[0] == -1.5);
  CHECK(std::isnan(v2[1]));
  CHECK(v2[2] == 2e-310);
  const std::size_t matrix_at = r.position();
  const Eigen::MatrixXd m2 = r.matrix();
  CHECK(m2 == m);
  // Documented order: rows, cols, then column 0 (1, 4), column 1 (2, 5), column 2 (3, 6).
  ByteReader raw(std::string_view(bytes).substr(matrix_at));
  CHECK(raw.u64() == 2);
  CHECK(raw.u64() == 3);
  for (const double expected : {1.0, 4.0, 2.0, 5.0, 3.0, 6.0}) CHECK(raw.f64() == expected);
  const Eigen::MatrixXd empty = r.matrix();
  CHECK(empty.rows() == 0);
  CHECK(empty.cols() == 4);
  CHECK(r.strings() == std::vector<std::string>{"", "E_X0C", "T_ENV"});
  CHECK(r.done());
}

TEST_CASE("byte codec: truncated or corrupt payloads throw, naming the field") {
  ByteWriter w;
  w.f64_vector({1.0, 2.0, 3.0});
  const std::string bytes = w.bytes();
  for (std::size_t cut = 0; cut < bytes.size(); ++cut) {
    ByteReader r(std::string_view(bytes).substr(0, cut), "snapshot");
    CHECK_THROWS_AS(r.f64_vector("residuals"), std::runtime_error);
  }
  ByteReader cut(std::string_view(bytes).substr(0, 20), "snapshot");
  CHECK_THROWS_WITH(cut.f64_vector("residuals"),
                    Contains("snapshot: ") && Contains("residuals") && Contains("3 element(s)") &&
                        Contains("12 bytes are left"));
  ByteReader short_f64(std::string_view(bytes).substr(0, 5), "snapshot");
  CHECK_THROWS_WITH(short_f64.f64("time_s"),
                    "snapshot: truncated: time_s at byte 0 needs 8 bytes, 5 left");

  // A length far beyond the payload is refused before anything is allocated.
  ByteWriter huge;
  huge.u64(std::numeric_limits<std::uint64_t>::max());
  ByteReader r1(huge.bytes());
  CHECK_THROWS_WITH(r1.string("name"), Contains("corrupt: name"));
  ByteReader r2(huge.bytes());
  CHECK_THROWS_WITH(r2.strings("names"), Contains("corrupt: names"));
  ByteWriter big_matrix;
  big_matrix.u64(1ULL << 40);
  big_matrix.u64(1ULL << 40);
  ByteReader r3(big_matrix.bytes());
  CHECK_THROWS_WITH(r3.matrix("model"), Contains("corrupt: model"));
  // An empty matrix with an absurd other dimension (found by fuzz/run_state_fuzz.cpp: 0 x 2^62 took
  // ages to walk) is refused; empty matrices of a sane size still read.
  ByteWriter empty_wide;
  empty_wide.u64(0);
  empty_wide.u64(1ULL << 62);
  ByteReader r6(empty_wide.bytes());
  CHECK_THROWS_WITH(r6.matrix("model"), Contains("corrupt: model") && Contains("0 x 4611686018427387904"));
  ByteWriter empty_ok;
  empty_ok.u64(0);
  empty_ok.u64(7);
  ByteReader r7(empty_ok.bytes());
  CHECK(r7.matrix("model").cols() == 7);

  ByteWriter not_bool;
  not_bool.u8(2);
  ByteReader r4(not_bool.bytes());
  CHECK_THROWS_WITH(r4.boolean("in_ng"), Contains("not a bool"));

  ByteWriter longer;
  longer.u32(1);
  longer.u8(0);
  ByteReader r5(longer.bytes(), "record");
  r5.u32();
  CHECK_FALSE(r5.done());
  CHECK_THROWS_WITH(r5.expect_done(), "record: corrupt: 1 byte(s) left over after byte 4");
}

TEST_CASE("byte codec: the header refuses another format and returns the version") {
  ByteWriter w;
  w.write_header("alc replay history", 3);
  ByteReader same(w.bytes());
  CHECK(same.read_header("alc replay history") == 3);
  ByteReader other(w.bytes(), "file x");
  CHECK_THROWS_WITH(other.read_header("alc study"), "file x: not a 'alc study' payload: foreign format");
  ByteReader garbage("PK\x03\x04 zip file", "file y");
  CHECK_THROWS_WITH(garbage.read_header("alc study"), Contains("not a 'alc study' payload"));
  ByteReader empty("");
  CHECK_THROWS_WITH(empty.read_header("alc study"), Contains("too short"));
  ByteReader no_version(std::string_view(w.bytes()).substr(0, w.bytes().size() - 2));
  CHECK_THROWS_WITH(no_version.read_header("alc replay history"), Contains("no version"));
}

TEST_CASE("checksum64: FNV-1a 64 reference values, and a changed byte changes it") {
  // Reference values of the FNV-1a 64 definition (offset basis, and the published test vector "a").
  CHECK(alc::common::checksum64("") == 0xcbf29ce484222325ULL);
  CHECK(alc::common::checksum64("a") == 0xaf63dc4c8601ec8cULL);
  CHECK(alc::common::checksum64("foobar") == 0x85944171f73967e8ULL);
  ByteWriter w;
  w.f64(1.0);
  std::string flipped = w.bytes();
  flipped[3] = static_cast<char>(flipped[3] ^ 0x10);
  CHECK(alc::common::checksum64(flipped) != alc::common::checksum64(w.bytes()));
}
