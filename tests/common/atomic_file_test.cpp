#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unistd.h>

#include "common/atomic_file.hpp"

namespace fs = std::filesystem;
using alc::io::write_file_atomically;
using Catch::Matchers::Contains;

namespace {

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("alc_common_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::set<std::string> names_in(const fs::path& dir) {
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
  return names;
}

}  // namespace

TEST_CASE("atomic file: writes a new file and replaces an existing one, leaving nothing else") {
  const fs::path dir = fresh_dir("write");
  const fs::path path = dir / "out.txt";
  write_file_atomically(path, std::string_view("first\n"));
  CHECK(read_text(path) == "first\n");
  write_file_atomically(path, std::string("with\0zero byte", 14));
  CHECK(read_text(path) == std::string("with\0zero byte", 14));
  write_file_atomically(path, std::string_view(""));
  CHECK(read_text(path).empty());
  std::string big(300000, 'x');  // beyond one buffer
  big.back() = '\n';
  write_file_atomically(path, [&](std::ostream& out) { out << big; });
  CHECK(read_text(path) == big);
  CHECK(names_in(dir) == std::set<std::string>{"out.txt"});
  fs::remove_all(dir);
}

TEST_CASE("atomic file: a stale temporary file of another writer is left alone") {
  const fs::path dir = fresh_dir("stale");
  const fs::path path = dir / "out.txt";
  const std::string stale_name = "out.txt.tmp." + std::to_string(::getpid()) + ".0";
  { std::ofstream(dir / "out.txt.tmp", std::ios::binary) << "stale\n"; }
  { std::ofstream(dir / stale_name, std::ios::binary) << "stale too\n"; }
  for (int i = 0; i < 3; ++i) write_file_atomically(path, std::string_view("new\n"));
  CHECK(read_text(path) == "new\n");
  CHECK(read_text(dir / "out.txt.tmp") == "stale\n");
  CHECK(read_text(dir / stale_name) == "stale too\n");
  CHECK(names_in(dir).size() == 3);
  fs::remove_all(dir);
}

TEST_CASE("atomic file: failures name the path and the cause and leave no temporary file") {
  const fs::path dir = fresh_dir("fail");
  SECTION("the directory does not exist") {
    const fs::path path = dir / "missing" / "out.txt";
    CHECK_THROWS_WITH(write_file_atomically(path, std::string_view("x")),
                      Contains("cannot write '" + path.string() + "'") && Contains("No such file or directory"));
    CHECK_FALSE(fs::exists(dir / "missing"));
  }
  SECTION("the target is a directory (not empty), which stays as it was") {
    const fs::path path = dir / "taken";
    fs::create_directories(path);
    { std::ofstream(path / "inside", std::ios::binary) << "x"; }
    CHECK_THROWS_WITH(write_file_atomically(path, std::string_view("text")),
                      Contains("cannot write '" + path.string() + "'") && Contains("it is a directory"));
    CHECK(read_text(path / "inside") == "x");
  }
  SECTION("the target is an empty directory") {
    const fs::path path = dir / "empty_dir";
    fs::create_directories(path);
    CHECK_THROWS_AS(write_file_atomically(path, std::string_view("text")), std::runtime_error);
    CHECK(fs::is_directory(path));
  }
  SECTION("a symbolic link is refused, whether it points to a file or nowhere (issue 13 item 7)") {
    const fs::path file = dir / "real.txt";
    write_file_atomically(file, std::string_view("real\n"));
    fs::create_symlink(file, dir / "link");
    fs::create_symlink(dir / "nowhere", dir / "dangling");
    for (const fs::path& link : {dir / "link", dir / "dangling"}) {
      CHECK_THROWS_WITH(write_file_atomically(link, std::string_view("text")),
                        Contains("cannot write '" + link.string() + "': it is a symbolic link"));
      CHECK(fs::is_symlink(link));
    }
    CHECK(read_text(file) == "real\n");
    CHECK_FALSE(fs::exists(dir / "nowhere"));
  }
  SECTION("a device node is refused and stays a device (issue 13 item 7)") {
    CHECK_THROWS_WITH(write_file_atomically("/dev/null", std::string_view("text")),
                      Contains("cannot write '/dev/null': it is a character device"));
    CHECK(fs::is_character_file("/dev/null"));
    for (const auto& name : names_in("/dev")) CHECK(name.find("null.tmp") == std::string::npos);
  }
  SECTION("the producer throws: its exception passes unchanged, the old file stays") {
    const fs::path path = dir / "keep.txt";
    write_file_atomically(path, std::string_view("original\n"));
    CHECK_THROWS_AS(write_file_atomically(path,
                                          [](std::ostream& out) {
                                            out << "half of it";
                                            throw std::invalid_argument("producer failed");
                                          }),
                    std::invalid_argument);
    CHECK(read_text(path) == "original\n");
  }
  SECTION("the stream fails: a write error, the target is not created") {
    const fs::path path = dir / "bad_stream.txt";
    CHECK_THROWS_WITH(write_file_atomically(path, [](std::ostream& out) { out.setstate(std::ios::badbit); }),
                      Contains("cannot write '" + path.string() + "'"));
    CHECK_FALSE(fs::exists(path));
  }
  // Whatever failed, the directory holds nothing of ours.
  for (const auto& name : names_in(dir)) CHECK(name.find(".tmp") == std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("atomic file: a read-only file is not replaced (also for root), a replaced file keeps its mode") {
  const fs::path dir = fresh_dir("modes");
  const fs::path kept = dir / "recorded.csv";
  write_file_atomically(kept, std::string_view("recorded\n"));
  fs::permissions(kept, fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);  // chmod 444
  // Before: replaced (root's access() allows it; the rename needs only the directory), mode 0644.
  CHECK_THROWS_WITH(write_file_atomically(kept, std::string_view("other\n")),
                    Contains("recorded.csv': it is a read-only file (mode 0444); it is not replaced"));
  CHECK(read_text(kept) == "recorded\n");
  CHECK_THAT(alc::io::output_file_problem(kept), Contains("read-only file (mode 0444)"));
  CHECK(names_in(dir) == std::set<std::string>{"recorded.csv"});
  // A private file stays private when replaced (before: 0600 came back as 0644).
  const fs::path secret = dir / "export.csv";
  write_file_atomically(secret, std::string_view("a\n"));
  fs::permissions(secret, fs::perms::owner_read | fs::perms::owner_write);
  write_file_atomically(secret, std::string_view("b\n"));
  CHECK(read_text(secret) == "b\n");
  CHECK((fs::status(secret).permissions() & fs::perms::all) == (fs::perms::owner_read | fs::perms::owner_write));
  fs::permissions(kept, fs::perms::owner_all);
  fs::remove_all(dir);
}
