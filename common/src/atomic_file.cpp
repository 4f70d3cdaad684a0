#include "common/atomic_file.hpp"

#include <fcntl.h>
#include <cstdio>  // renameat2, RENAME_NOREPLACE (glibc >= 2.28)
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <streambuf>
#include <string>
#include <system_error>
#include <vector>

namespace alc::io {
namespace {

// Built by appending: GCC 12 warns (-Wrestrict, a false positive) about "'" + std::string.
std::string quoted(const std::filesystem::path& p) {
  std::string q(1, '\'');
  q.append(p.string()).push_back('\'');
  return q;
}

// A buffered output stream on a file descriptor that remembers the errno of a failed write (an
// std::ofstream says only that it failed, and cannot fsync).
class FdBuffer : public std::streambuf {
 public:
  explicit FdBuffer(int fd) : fd_(fd), buffer_(1 << 16) { setp(buffer_.data(), buffer_.data() + buffer_.size()); }
  int error() const { return error_; }

 protected:
  int_type overflow(int_type ch) override {
    if (!drain()) return traits_type::eof();
    if (!traits_type::eq_int_type(ch, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(ch);
      pbump(1);
    }
    return traits_type::not_eof(ch);
  }
  int sync() override { return drain() ? 0 : -1; }

 private:
  bool drain() {
    const char* data = pbase();
    std::size_t left = static_cast<std::size_t>(pptr() - pbase());
    while (left > 0) {
      const ssize_t n = ::write(fd_, data, left);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        error_ = n < 0 ? errno : EIO;
        return false;
      }
      data += n;
      left -= static_cast<std::size_t>(n);
    }
    setp(buffer_.data(), buffer_.data() + buffer_.size());
    return true;
  }

  int fd_;
  std::vector<char> buffer_;
  int error_ = 0;
};

// Creates PATH.tmp.<pid>.<n> exclusively (a name nobody else holds); returns its descriptor.
int create_temporary(const std::filesystem::path& path, std::filesystem::path& temporary) {
  static std::atomic<unsigned> counter{0};
  for (int attempt = 0;; ++attempt) {
    temporary = path;
    temporary += ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
    const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) return fd;
    if (errno != EEXIST || attempt >= 100)
      throw std::runtime_error("cannot write " + quoted(path) + ": cannot create a temporary file beside it (" +
                               quoted(temporary) + "): " + std::strerror(errno));
  }
}

// Makes the rename itself durable (best effort: some file systems cannot sync a directory).
void sync_directory(const std::filesystem::path& path) {
  const std::filesystem::path dir = path.parent_path().empty() ? "." : path.parent_path();
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

// Why the rename must not replace `path` (empty for a writable regular file or a new path): "it is"
// a symbolic link (the rename would put a regular file in place of the link, not write where it
// points), a directory, a device node, a pipe, a socket, or a read-only file.
std::string not_replaceable(const std::filesystem::path& path) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) return {};  // a new path (or one the create below reports)
  if (S_ISREG(st.st_mode)) {
    if (!read_only_file(path)) return {};
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    return std::string("it is a read-only file (mode ") + mode + "); it is not replaced: make it writable or give "
           "another path";
  }
  const char* what = S_ISLNK(st.st_mode)    ? "a symbolic link"
                     : S_ISDIR(st.st_mode)  ? "a directory"
                     : S_ISCHR(st.st_mode)  ? "a character device"
                     : S_ISBLK(st.st_mode)  ? "a block device"
                     : S_ISFIFO(st.st_mode) ? "a pipe"
                                            : "a socket or another special file";
  return std::string("it is ") + what + ", not a regular file; give a regular file or a new path";
}

}  // namespace

std::string output_file_problem(const std::filesystem::path& path) {
  if (std::string why = not_replaceable(path); !why.empty()) return why;
  const std::filesystem::path dir = path.parent_path().empty() ? "." : path.parent_path();
  struct stat st {};
  if (::stat(dir.c_str(), &st) != 0) return "its directory " + quoted(dir) + " cannot be used: " + std::strerror(errno);
  if (!S_ISDIR(st.st_mode)) return quoted(dir) + " is not a directory";
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    return "its directory " + quoted(dir) + " is not writable: " + std::strerror(errno);
  return {};
}

// Both forms: `replace` renames over `path`; else the file is linked to `path`, which fails with
// EEXIST if anything holds that name (then false, nothing written).
static bool write_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write,
                      bool replace) {
  if (const std::string why = not_replaceable(path); replace && !why.empty())
    throw std::runtime_error("cannot write " + quoted(path) + ": " + why);
  std::filesystem::path temporary;
  int fd = create_temporary(path, temporary);
  // From here on the temporary file is ours: on any failure it goes, and `path` stays as it was.
  const auto discard = [&] {
    if (fd >= 0) ::close(fd);
    fd = -1;
    ::unlink(temporary.c_str());
  };
  const auto failed = [&](const std::string& what, int error) {
    discard();
    throw std::runtime_error("cannot write " + quoted(path) + ": " + what + ": " + std::strerror(error));
  };
  {
    FdBuffer buffer(fd);
    std::ostream out(&buffer);
    try {
      write(out);
      out.flush();
    } catch (...) {
      discard();
      throw;
    }
    if (!out) failed("writing " + quoted(temporary) + " failed", buffer.error() != 0 ? buffer.error() : EIO);
  }
  // A file replaced keeps its mode (a 0600 history export stays private), a new one gets 0666 & ~umask.
  if (struct stat st {}; replace && ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode))
    if (::fchmod(fd, st.st_mode & 07777) != 0) failed("chmod of " + quoted(temporary) + " failed", errno);
  if (::fsync(fd) != 0) failed("fsync of " + quoted(temporary) + " failed", errno);
  const int closed = ::close(fd);
  fd = -1;
  if (closed != 0) failed("closing " + quoted(temporary) + " failed", errno);
  if (replace) {
    if (::rename(temporary.c_str(), path.c_str()) != 0)
      failed("cannot rename " + quoted(temporary) + " into place", errno);
  } else if (::link(temporary.c_str(), path.c_str()) == 0) {
    ::unlink(temporary.c_str());
  } else {
    int error = errno;
    // A file system without hard links (vfat, exFAT, some FUSE and SMB mounts): a rename that
    // refuses to replace (Linux's renameat2, RENAME_NOREPLACE); where that is not offered either,
    // a plain rename after a look, which two writers could race (said in the header).
    if (error == EPERM || error == EOPNOTSUPP || error == ENOTSUP || error == EMLINK || error == ENOSYS) {
      if (::renameat2(AT_FDCWD, temporary.c_str(), AT_FDCWD, path.c_str(), RENAME_NOREPLACE) == 0) {
        sync_directory(path);
        return true;
      }
      error = errno;
      if (error == EINVAL || error == ENOSYS) {
        struct stat st {};
        if (::lstat(path.c_str(), &st) == 0) error = EEXIST;
        else if (::rename(temporary.c_str(), path.c_str()) == 0) error = 0;
        else error = errno;
      }
      if (error == 0) {
        sync_directory(path);
        return true;
      }
    }
    if (error == EEXIST) {
      discard();
      return false;
    }
    failed("cannot link " + quoted(temporary) + " into place", error);
  }
  sync_directory(path);
  return true;
}

void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write) {
  write_atomically(path, write, true);
}

void write_file_atomically(const std::filesystem::path& path, std::string_view text) {
  write_file_atomically(path, [text](std::ostream& out) { out.write(text.data(), static_cast<std::streamsize>(text.size())); });
}

bool write_new_file_atomically(const std::filesystem::path& path, std::string_view text) {
  return write_atomically(
      path, [text](std::ostream& out) { out.write(text.data(), static_cast<std::streamsize>(text.size())); }, false);
}

bool read_only_file(const std::filesystem::path& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return false;
  // No write bit at all (chmod 444) protects the file from root too, whom access() lets write.
  return (st.st_mode & 0222) == 0 || ::access(path.c_str(), W_OK) != 0;
}

}  // namespace alc::io
