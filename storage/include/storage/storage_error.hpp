#pragma once
// The one exception type of the storage layer. The message names the file and the cause.
#include <filesystem>
#include <stdexcept>
#include <string>

namespace alc::storage {

enum class StorageErrorKind {
  NotADatabase,     // the file is not an SQLite database (no SQLite header)
  Empty,            // opened for reading: no bytes, or an SQLite database with no table and no
                    // application_id (what a writer killed before its first commit leaves)
  ForeignDatabase,  // an SQLite database of another program (application_id or tables)
  NewerSchema,      // written by a newer ALC (user_version above ours)
  Locked,           // another connection holds the write lock longer than the busy timeout
  Corrupt,          // truncated or damaged file
  ReadOnly,         // the file or its directory cannot be written
  DiskFull,         // no space left (or the max_page_count cap reached)
  NotFound,         // the file (or a run, table, snapshot) does not exist
  InvalidArgument,  // a record or argument that breaks the contract (wrong vector length, ...)
  Io,               // any other SQLite or file-system failure
};

const char* to_string(StorageErrorKind kind);

class StorageError : public std::runtime_error {
 public:
  StorageError(StorageErrorKind kind, std::filesystem::path file, std::string reason);
  StorageErrorKind kind;
  std::filesystem::path file;
  std::string reason;  // the bare cause, without the file name
};

}  // namespace alc::storage
