#pragma once
// The one check of a path given as input (a scenario CSV, a machine config, NC command lines, a
// grid): a directory opens as a stream that reads nothing, so without this check a directory reads
// as an empty file and its defaults are used silently.
#include <filesystem>
#include <string>

namespace alc::io {

// "a directory", "a pipe", "a character device", "a block device", "a socket", else "not a file".
const char* file_type_name(std::filesystem::file_type type);

// Empty when `path` can be read as an input file: a regular file, or a stream that is read like one
// (a pipe, a character device such as /dev/stdin), or a path that does not exist (opening it then
// says so). Else why not: "not a regular file (a directory)".
std::string input_file_problem(const std::filesystem::path& path);

}  // namespace alc::io
