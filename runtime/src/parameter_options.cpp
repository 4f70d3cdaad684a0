#include "runtime/parameter_options.hpp"

#include <charconv>
#include <cmath>
#include <stdexcept>

#include "common/number_text.hpp"

namespace alc::runtime {

namespace {

constexpr std::string_view kNumber = "a number >= 0";
constexpr std::string_view kNumberOrInf = "a number >= 0 or inf";
constexpr std::string_view kFlag = "true or false";

[[noreturn]] void refuse(std::string_view name, std::string_view text, std::string_view values) {
  throw std::invalid_argument(std::string(name) + ": '" + std::string(text) + "' is not " + std::string(values));
}

bool parse_flag(std::string_view name, std::string_view text) {
  if (text == "true") return true;
  if (text == "false") return false;
  refuse(name, text, kFlag);
}

}  // namespace

const std::vector<ParameterOption>& parameter_options() {
  static const std::vector<ParameterOption> options = {
      {"cp", "h", kNumber, "Calibration phase length", Stage::Start},
      {"cp-interval", "min", kNumber, "Probe interval during CP", Stage::Start},
      {"interval", "h", kNumberOrInf, "Probe interval after CP (inf: no probes after CP)", Stage::CpEnd},
      {"ng-interval", "min", kNumberOrInf, "Probe interval in the No-Good phase (inf: no NG burst)", Stage::Breach},
      {"ng-meas", "-", kNumberOrInf, "Probes in a No-Good phase before the update", Stage::Breach},
      {"update", "h", kNumberOrInf, "Periodic parameter update interval", Stage::CpEnd},
      {"acl-lin", "µm", kNumber, "Action control limit of linear errors", Stage::CpEnd},
      {"acl-ang", "µm/m", kNumber, "Action control limit of angular errors", Stage::CpEnd},
      {"window", "h", kNumberOrInf, "Re-identify on the data of the last H hours (inf: all data)", Stage::Start},
      {"since", "h", kNumber, "Re-identify only on probes from this scenario time on", Stage::Start},
      {"half-life", "h", kNumberOrInf, "Forgetting: a probe's weight halves every H hours", Stage::Start},
      {"method", "-", "fixed-poles or output-error", "Identification route", Stage::Start},
      {"max-order", "-", "a whole number >= 1", "Highest number of poles per input tried", Stage::Start},
      {"structure-refresh", "-", kNumberOrInf, "Data-span growth factor that triggers a structure search",
       Stage::CpEnd},
      {"no-refit", "-", kFlag, "Re-identify only at the end of CP, after NG and at --update", Stage::CpEnd},
      {"no-confirm", "-", kFlag, "Learn from a breaching probe at once (no confirmation)", Stage::Breach},
      {"schedule", "-", "paper or adaptive", "Post-CP probing: seed 004's fixed interval, or when the model is unsure",
       Stage::CpEnd},
      {"uncertainty-fraction", "-", "a number > 0",
       "Adaptive: probe when the predicted sigma of the compensated error reaches this x ACL (above 1: a budget "
       "beyond the ACL)", Stage::CpEnd},
      {"min-interval", "h", kNumber, "Adaptive: shortest Post-CP interval", Stage::CpEnd},
      {"max-interval", "h", kNumberOrInf, "Adaptive: longest Post-CP interval (inf: no bound, the evidence alone)",
       Stage::CpEnd},
      {"guard", "-", kFlag, "Back compensation off where it does no good on recent probes (default true)",
       Stage::CpEnd},
      {"plausible-lin", "µm", kNumberOrInf,
       "A probe's linear error beyond ± this is a sensor fault: set aside for that output (inf: no limit)", Stage::Start},
      {"plausible-ang", "µm/m", kNumberOrInf,
       "A probe's angular error beyond ± this is a sensor fault: set aside for that output (inf: no limit)",
       Stage::Start},
      {"plausible-temp", "°C", kNumberOrInf,
       "A temperature input (T_...) beyond ± this is a sensor fault: the sample is set aside (inf: no limit)",
       Stage::Start},
      {"plausible-speed", "rpm", kNumberOrInf,
       "A speed input (n_...) beyond ± this is a sensor fault: the sample is set aside (inf: no limit)", Stage::Start},
      {"plausible-other", "-", kNumberOrInf,
       "Any other input (machine states, ...) beyond ± this is a sensor fault: the sample is set aside (inf: no limit)",
       Stage::Start},
  };
  return options;
}

const ParameterOption* find_parameter_option(std::string_view name) {
  for (const ParameterOption& o : parameter_options())
    if (o.name == name) return &o;
  return nullptr;
}

void set_parameter(AlcParameters& p, std::string_view name, std::string_view text) {
  const ParameterOption* o = find_parameter_option(name);
  if (!o) throw std::invalid_argument("'" + std::string(name) + "' is not a parameter option");
  const auto number = [&](double scale) { return common::parse_number(name, text, false) * scale; };
  const auto number_or_inf = [&](double scale) { return common::parse_number(name, text, true) * scale; };
  if (name == "cp") p.cp_duration_s = number(3600.0);
  else if (name == "cp-interval") p.cp_interval_s = number(60.0);
  else if (name == "interval") p.post_cp_interval_s = number_or_inf(3600.0);
  else if (name == "ng-interval") p.ng_interval_s = number_or_inf(60.0);
  else if (name == "ng-meas") p.ng_measurements = number_or_inf(1.0);
  else if (name == "update") p.update_interval_s = number_or_inf(3600.0);
  else if (name == "acl-lin") p.acl_linear_um = number(1.0);
  else if (name == "acl-ang") p.acl_angular_um_per_m = number(1.0);
  else if (name == "window") p.learning_window_s = number_or_inf(3600.0);
  else if (name == "since") p.learning_since_s = number(3600.0);
  else if (name == "half-life") p.identification.forgetting_half_life_s = number_or_inf(3600.0);
  else if (name == "structure-refresh") p.structure_refresh = number_or_inf(1.0);
  else if (name == "no-refit") p.refit_on_probe = !parse_flag(name, text);
  else if (name == "no-confirm") p.confirm_breach = !parse_flag(name, text);
  else if (name == "guard") p.guard = parse_flag(name, text);
  else if (name == "uncertainty-fraction") p.uncertainty_fraction = number(1.0);
  else if (name == "min-interval") p.min_interval_s = number(3600.0);
  else if (name == "max-interval") p.max_interval_s = number_or_inf(3600.0);
  else if (name == "plausible-lin") p.plausible_linear_um = number_or_inf(1.0);
  else if (name == "plausible-ang") p.plausible_angular_um_per_m = number_or_inf(1.0);
  else if (name == "plausible-temp") p.plausible_temperature_C = number_or_inf(1.0);
  else if (name == "plausible-speed") p.plausible_speed_rpm = number_or_inf(1.0);
  else if (name == "plausible-other") p.plausible_other = number_or_inf(1.0);
  else if (name == "schedule") {
    if (text == "paper") p.schedule_kind = AlcParameters::Schedule::Paper;
    else if (text == "adaptive") p.schedule_kind = AlcParameters::Schedule::Adaptive;
    else refuse(name, text, o->values);
  }
  else if (name == "method") {
    if (text == "fixed-poles") p.identification.method = IdentificationMethod::FixedPoles;
    else if (text == "output-error") p.identification.method = IdentificationMethod::OutputError;
    else refuse(name, text, o->values);
  } else if (name == "max-order") {
    const double v = number(1.0);
    if (v < 1.0 || v > 16.0 || v != std::floor(v)) refuse(name, text, o->values);
    p.identification.max_order = static_cast<int>(v);
  }
}

AlcParameters parameters_of(const OptionTexts& options) {
  AlcParameters p;
  for (const auto& [name, text] : options) set_parameter(p, name, text);
  // Without refits on probes a breach cannot be confirmed: the paper's literal loop.
  if (!p.refit_on_probe) p.confirm_breach = false;
  if (const std::string why = p.validate(); !why.empty()) throw InvalidParameters("invalid parameters: " + why);
  return p;
}

}  // namespace alc::runtime
