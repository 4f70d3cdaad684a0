#pragma once
// Kinds of thermal location errors and their action control limits.
#include <string_view>

namespace alc {

// Linear errors are in [µm], angular errors (E_A…, E_B…, E_C…) in [µm/m] (= µrad).
enum class ErrorKind { Linear, Angular };

// True for a measured-error column name of the scenario CSV contract (prefix "E_").
bool is_error_name(std::string_view name);

// Kind of an error from its ISO 230-7 style name: "E_A0C" -> Angular, "E_X0C" -> Linear.
ErrorKind error_kind(std::string_view name);

// Unit of an error kind as printed in tables: "µm" or "µm/m".
std::string_view unit_of(ErrorKind kind);

// Kinds of model inputs, told by the column name (docs/design.md, "Scenario CSV"): "T_…" a
// temperature [°C], "n_…" a speed [rpm], anything else another quantity (0/1 machine states, …).
// The kind only chooses the plausibility limit of a reading (AlcParameters::plausible_*).
enum class InputKind { Temperature, Speed, Other };
InputKind input_kind(std::string_view name);
// "°C", "rpm" or "" (no unit known).
std::string_view unit_of(InputKind kind);

}  // namespace alc
