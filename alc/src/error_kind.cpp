#include "alc/error_kind.hpp"

namespace alc {

bool is_error_name(std::string_view name) { return name.size() > 2 && name.substr(0, 2) == "E_"; }

ErrorKind error_kind(std::string_view name) {
  if (is_error_name(name)) {
    const char axis = name[2];
    if (axis == 'A' || axis == 'B' || axis == 'C') return ErrorKind::Angular;
  }
  return ErrorKind::Linear;
}

std::string_view unit_of(ErrorKind kind) { return kind == ErrorKind::Angular ? "µm/m" : "µm"; }

InputKind input_kind(std::string_view name) {
  if (name.size() > 2 && name.substr(0, 2) == "T_") return InputKind::Temperature;
  if (name.size() > 2 && name.substr(0, 2) == "n_") return InputKind::Speed;
  return InputKind::Other;
}

std::string_view unit_of(InputKind kind) {
  return kind == InputKind::Temperature ? "°C" : kind == InputKind::Speed ? "rpm" : "";
}

}  // namespace alc
