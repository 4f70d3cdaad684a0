#include "runtime/parameter_options.hpp"

#include <cctype>
#include <charconv>
#include <cmath>
#include <stdexcept>

#include "common/number_text.hpp"

namespace alc::runtime {

namespace {

// A row of the table (choices: Domain::Choice's words).
ParameterOption row(std::string_view name, std::string_view unit, Domain domain, std::string_view help, Stage stage,
                    std::string_view field, std::string_view choices = {}) {
  return ParameterOption{name, unit, domain, help, stage, field, choices};
}

[[noreturn]] void refuse(std::string_view name, std::string_view text, const std::string& values) {
  throw std::invalid_argument(std::string(name) + ": '" + std::string(text) + "' is not " + values);
}

}  // namespace

const std::vector<ParameterOption>& parameter_options() {
  static const std::vector<ParameterOption> options = {
      row("cp", "h", Domain::Positive, "Calibration phase length", Stage::Start, "cp_duration_s"),
      row("cp-interval", "min", Domain::Positive, "Probe interval during CP", Stage::Start, "cp_interval_s"),
      row("interval", "h", Domain::PositiveOrInf, "Probe interval after CP (inf: no probes after CP)", Stage::CpEnd, "post_cp_interval_s"),
      row("ng-interval", "min", Domain::PositiveOrInf, "Probe interval in the No-Good phase (inf: no NG burst)", Stage::Breach, "ng_interval_s"),
      row("ng-meas", "-", Domain::WholeOrInf, "Probes in a No-Good phase before the update", Stage::Breach, "ng_measurements"),
      row("update", "h", Domain::PositiveOrInf, "Periodic parameter update interval", Stage::CpEnd, "update_interval_s"),
      row("acl-lin", "µm", Domain::Positive, "Action control limit of linear errors", Stage::CpEnd, "acl_linear_um"),
      row("acl-ang", "µm/m", Domain::Positive, "Action control limit of angular errors", Stage::CpEnd, "acl_angular_um_per_m"),
      row("window", "h", Domain::PositiveOrInf, "Re-identify on the data of the last H hours (inf: all data)", Stage::Start, "learning_window_s"),
      row("since", "h", Domain::NonNegative, "Re-identify only on probes from this scenario time on", Stage::Start, "learning_since_s"),
      row("half-life", "h", Domain::PositiveOrInf, "Forgetting: a probe's weight halves every H hours", Stage::Start, "forgetting_half_life_s"),
      row("method", "-", Domain::Choice, "Identification route", Stage::Start, "method", "fixed-poles or output-error"),
      row("max-order", "-", Domain::Order, "Highest number of poles per input tried", Stage::Start, "max_order"),
      row("structure-refresh", "-", Domain::AtLeastOneOrInf, "Data-span growth factor that triggers a structure search",
       Stage::CpEnd, "structure_refresh"),
      row("no-refit", "-", Domain::Flag, "Re-identify only at the end of CP, after NG and at --update", Stage::CpEnd, "refit_on_probe"),
      row("no-confirm", "-", Domain::Flag, "Learn from a breaching probe at once (no confirmation)", Stage::Breach, "confirm_breach"),
      row("schedule", "-", Domain::Choice, "Post-CP probing: seed 004's fixed interval, or when the model is unsure",
       Stage::CpEnd, "schedule_kind", "paper or adaptive"),
      row("uncertainty-fraction", "-", Domain::Positive,
       "Adaptive: probe when the predicted sigma of the compensated error reaches this x ACL (above 1: a budget "
       "beyond the ACL)", Stage::CpEnd, "uncertainty_fraction"),
      row("min-interval", "h", Domain::Positive, "Adaptive: shortest Post-CP interval", Stage::CpEnd, "min_interval_s"),
      row("max-interval", "h", Domain::PositiveOrInf, "Adaptive: longest Post-CP interval (inf: no bound, the evidence alone)",
       Stage::CpEnd, "max_interval_s"),
      row("guard", "-", Domain::Flag, "Back compensation off where it does no good on recent probes (default true)",
       Stage::CpEnd, "guard"),
      row("move-fraction", "-", Domain::PositiveOrInf,
       "Guard: probe as soon as an output's compensation has moved this x its ACL since the last probe (inf: "
       "no move check; without it outputs end worse than uncompensated far more often, docs/adaptive.md)", Stage::CpEnd,
       "move_fraction"),
      row("plausible-lin", "µm", Domain::PositiveOrInf,
       "A probe's linear error beyond ± this is a sensor fault: set aside for that output (inf: no limit)", Stage::Start, "plausible_linear_um"),
      row("plausible-ang", "µm/m", Domain::PositiveOrInf,
       "A probe's angular error beyond ± this is a sensor fault: set aside for that output (inf: no limit)",
       Stage::Start, "plausible_angular_um_per_m"),
      row("plausible-temp", "°C", Domain::PositiveOrInf,
       "A temperature input (T_...) beyond ± this is a sensor fault: the sample is set aside (inf: no limit)",
       Stage::Start, "plausible_temperature_C"),
      row("plausible-speed", "rpm", Domain::PositiveOrInf,
       "A speed input (n_...) beyond ± this is a sensor fault: the sample is set aside (inf: no limit)", Stage::Start, "plausible_speed_rpm"),
      row("plausible-other", "-", Domain::PositiveOrInf,
       "Any other input (machine states, ...) beyond ± this is a sensor fault: the sample is set aside (inf: no limit)",
       Stage::Start, "plausible_other"),
  };
  return options;
}

std::string values_text(const ParameterOption& option) {
  switch (option.domain) {
    case Domain::NonNegative: return "a number >= 0";
    case Domain::Positive: return "a number > 0";
    case Domain::PositiveOrInf: return "a number > 0 or inf";
    case Domain::AtLeastOneOrInf: return "a number >= 1 or inf";
    case Domain::WholeOrInf: return "a whole number >= 0 or inf";
    case Domain::Order: return "a whole number from 1 to 16";
    case Domain::Flag: return "true or false";
    case Domain::Choice: return std::string(option.choices);
  }
  return {};
}

const ParameterOption* find_parameter_option(std::string_view name) {
  for (const ParameterOption& o : parameter_options())
    if (o.name == name) return &o;
  return nullptr;
}

void set_parameter(AlcParameters& p, std::string_view name, std::string_view text) {
  const ParameterOption* o = find_parameter_option(name);
  if (!o) throw std::invalid_argument("'" + std::string(name) + "' is not a parameter option");
  // Each value parsed and checked by its option's domain, so that a grid is judged value by value
  // before any run: "interval = [0]" is refused there, not found as error rows after the study.
  const auto value = [&](double scale) {
    const Domain d = o->domain;
    const bool inf = d == Domain::PositiveOrInf || d == Domain::AtLeastOneOrInf || d == Domain::WholeOrInf;
    double v = 0.0;
    try {
      v = common::parse_number(name, text, true);
    } catch (const std::invalid_argument& e) {
      // "1e999": parse_number's own words say more; anything else is not a value of the domain.
      if (std::string_view(e.what()).find("out of the range") != std::string_view::npos) throw;
      refuse(name, text, values_text(*o));
    }
    if (std::isinf(v) && !inf) refuse(name, text, values_text(*o));
    const bool ok = d == Domain::Positive || d == Domain::PositiveOrInf ? v > 0.0
                    : d == Domain::AtLeastOneOrInf                       ? v >= 1.0
                    : d == Domain::WholeOrInf                            ? (std::isinf(v) || v == std::floor(v))
                    : d == Domain::Order                                 ? (v >= 1.0 && v <= 16.0 && v == std::floor(v))
                                                                         : d == Domain::NonNegative;
    if (!ok) refuse(name, text, values_text(*o));
    // A length of time below a second is no time the controller can tell from 0 on a clock of seconds
    // (1e-20 h added to a sample's time leaves it as it was: no probe after CP at all).
    if ((o->unit == "h" || o->unit == "min") && d != Domain::NonNegative && std::isfinite(v) && v * scale < 1.0)
      throw std::invalid_argument(std::string(name) + ": '" + std::string(text) + "' " + std::string(o->unit) +
                                  " is shorter than 1 s, no time the controller can tell from 0");
    return v * scale;
  };
  const auto flag = [&] {
    if (text == "true") return true;
    if (text == "false") return false;
    refuse(name, text, values_text(*o));
  };
  if (name == "cp") p.cp_duration_s = value(3600.0);
  else if (name == "cp-interval") p.cp_interval_s = value(60.0);
  else if (name == "interval") p.post_cp_interval_s = value(3600.0);
  else if (name == "ng-interval") p.ng_interval_s = value(60.0);
  else if (name == "ng-meas") p.ng_measurements = value(1.0);
  else if (name == "update") p.update_interval_s = value(3600.0);
  else if (name == "acl-lin") p.acl_linear_um = value(1.0);
  else if (name == "acl-ang") p.acl_angular_um_per_m = value(1.0);
  else if (name == "window") p.learning_window_s = value(3600.0);
  else if (name == "since") p.learning_since_s = value(3600.0);
  else if (name == "half-life") p.identification.forgetting_half_life_s = value(3600.0);
  else if (name == "structure-refresh") p.structure_refresh = value(1.0);
  else if (name == "no-refit") p.refit_on_probe = !flag();
  else if (name == "no-confirm") p.confirm_breach = !flag();
  else if (name == "guard") p.guard = flag();
  else if (name == "move-fraction") p.move_fraction = value(1.0);
  else if (name == "uncertainty-fraction") p.uncertainty_fraction = value(1.0);
  else if (name == "min-interval") p.min_interval_s = value(3600.0);
  else if (name == "max-interval") p.max_interval_s = value(3600.0);
  else if (name == "plausible-lin") p.plausible_linear_um = value(1.0);
  else if (name == "plausible-ang") p.plausible_angular_um_per_m = value(1.0);
  else if (name == "plausible-temp") p.plausible_temperature_C = value(1.0);
  else if (name == "plausible-speed") p.plausible_speed_rpm = value(1.0);
  else if (name == "plausible-other") p.plausible_other = value(1.0);
  else if (name == "schedule") {
    if (text == "paper") p.schedule_kind = AlcParameters::Schedule::Paper;
    else if (text == "adaptive") p.schedule_kind = AlcParameters::Schedule::Adaptive;
    else refuse(name, text, values_text(*o));
  }
  else if (name == "method") {
    if (text == "fixed-poles") p.identification.method = IdentificationMethod::FixedPoles;
    else if (text == "output-error") p.identification.method = IdentificationMethod::OutputError;
    else refuse(name, text, values_text(*o));
  } else if (name == "max-order") {
    p.identification.max_order = static_cast<int>(value(1.0));
  }
}

namespace {
// The text an option was given (the last of an option given twice wins), or none.
const std::string* given_text(const OptionTexts& given, std::string_view name) {
  for (auto it = given.rbegin(); it != given.rend(); ++it)
    if (it->first == name) return &it->second;
  return nullptr;
}

// A constraint of validate() ("must not be below min_interval_s") with each field it names given as its
// option and the option's text with its unit where it was given: "must not be below min-interval = 2 h".
std::string constraint_by_option(std::string_view constraint, const OptionTexts& given) {
  std::string out;
  const auto word_char = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
  for (std::size_t i = 0; i < constraint.size();) {
    if (!word_char(constraint[i])) {
      out += constraint[i++];
      continue;
    }
    std::size_t j = i;
    while (j < constraint.size() && word_char(constraint[j])) ++j;
    const std::string_view word = constraint.substr(i, j - i);
    const ParameterOption* named = nullptr;  // a field is a word with '_' ("cp_duration_s"), not "guard"
    if (word.find('_') != std::string_view::npos)
      for (const ParameterOption& o : parameter_options())
        if (o.field == word) named = &o;
    if (!named) {
      out += word;
    } else {
      out += named->name;
      if (const std::string* text = given_text(given, named->name)) {
        out += " = " + *text;
        if (named->unit != "-" && *text != "inf") out += " " + std::string(named->unit);
      }
    }
    i = j;
  }
  return out;
}

// validate()'s "field = value: constraint" (or "identification: IdentificationOptions.field = ...") led
// by the option that sets the field and its text, where it has one: "cp = 0 (cp_duration_s = 0): ...";
// the fields the constraint names are given as their options: "... must not exceed cp = 1 h".
std::string named_by_option(const std::string& why, const OptionTexts& given) {
  std::string_view rest = why;
  if (const auto colon = rest.find(": "); colon != std::string_view::npos && rest.substr(0, colon) == "identification")
    rest.remove_prefix(colon + 2);
  const auto eq = rest.find(" = ");
  const auto end = rest.find(": ");
  if (eq == std::string_view::npos || end == std::string_view::npos || end < eq) return why;
  std::string_view field = rest.substr(0, eq);
  if (const auto dot = field.rfind('.'); dot != std::string_view::npos) field.remove_prefix(dot + 1);  // Options.x
  for (const ParameterOption& o : parameter_options()) {
    if (o.field != field) continue;
    if (const std::string* text = given_text(given, o.name))
      return std::string(o.name) + " = " + *text + " (" + std::string(rest.substr(0, end)) + ")" +
             constraint_by_option(rest.substr(end), given);
  }
  return why;
}
}  // namespace

AlcParameters parameters_of(const OptionTexts& options) {
  AlcParameters p;
  for (const auto& [name, text] : options) set_parameter(p, name, text);
  // Without refits on probes a breach cannot be confirmed: the paper's literal loop.
  if (!p.refit_on_probe) p.confirm_breach = false;
  if (const std::string why = p.validate(); !why.empty())
    throw InvalidParameters("invalid parameters: " + named_by_option(why, options));
  return p;
}

}  // namespace alc::runtime
