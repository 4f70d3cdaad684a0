#include "common/input_file.hpp"

namespace alc::io {

const char* file_type_name(std::filesystem::file_type type) {
  switch (type) {
    case std::filesystem::file_type::directory: return "a directory";
    case std::filesystem::file_type::fifo: return "a pipe";
    case std::filesystem::file_type::character: return "a character device";
    case std::filesystem::file_type::block: return "a block device";
    case std::filesystem::file_type::socket: return "a socket";
    default: return "not a file";
  }
}

std::string input_file_problem(const std::filesystem::path& path) {
  std::error_code ec;
  const auto type = std::filesystem::status(path, ec).type();
  if (ec || type == std::filesystem::file_type::not_found || type == std::filesystem::file_type::regular ||
      type == std::filesystem::file_type::fifo || type == std::filesystem::file_type::character)
    return {};
  return std::string("not a regular file (") + file_type_name(type) + ")";
}

}  // namespace alc::io
