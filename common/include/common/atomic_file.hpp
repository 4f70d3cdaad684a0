#pragma once
// The one way the project replaces a file: a reader (or a crash) never sees half of it.
#include <filesystem>
#include <functional>
#include <ostream>
#include <string>
#include <string_view>

namespace alc::io {

// Writes `text` to `path` atomically: into a new temporary file beside `path` (same directory,
// a name of its own: PATH.tmp.<pid>.<n>, created exclusively, so neither a stale file of an earlier
// crash nor another writer is touched), flushed and fsync'ed, then renamed over `path`. `path` must
// be a regular file or a new path: a symbolic link, a directory, a device node, a pipe or a socket
// is refused before anything is created (the rename would replace it with a regular file; there is
// no write-through), and so is a read-only file (no write bit, or not writable by us: also for root,
// whom a rename would let replace it). A file replaced keeps its mode. On any failure the temporary file is removed, `path` is left as it was, and
// std::runtime_error says "cannot write 'PATH': " and the cause (no such directory, it is a
// symbolic link, disk full).
void write_file_atomically(const std::filesystem::path& path, std::string_view text);

// True for a regular file this process must not replace: no write bit at all (chmod 444, which
// protects it from root too, whom access() lets write) or no write permission for this user. The
// one judgement of "read-only" for output files and for the history writer.
bool read_only_file(const std::filesystem::path& path);

// Why write_file_atomically(path) would fail before it writes anything (for a check before long
// work whose result goes there): `path` is not replaceable (above), or its directory is missing, not a
// directory, or not writable. Empty when nothing is known to stand in the way.
std::string output_file_problem(const std::filesystem::path& path);

// The same for a text produced as a stream: `write` fills the stream. An exception from `write`
// propagates as it is (after the temporary file is removed); a failed stream is a write error.
void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write);

// The same, but never over a file: `path` is claimed with link(2), so of two writers of the same new
// name one wins and the other gets false (its temporary file removed, nothing written); false too if
// `path` exists already, whatever it is. True when the file is in place. On a file system without
// hard links (vfat, exFAT, some FUSE and SMB mounts) renameat2(RENAME_NOREPLACE) claims it; where
// neither is offered, a rename after a look, which two writers at the same instant could race.
bool write_new_file_atomically(const std::filesystem::path& path, std::string_view text);

}  // namespace alc::io
