#include "probing/twin_probe.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "common/quantise.hpp"

namespace alc::probing {

namespace {

void check(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("TwinProbe: " + what);
}

void validate(const TwinProbeOptions& o) {
  check(!o.noise_sigma.empty(), "noise_sigma must name at least one output");
  for (double s : o.noise_sigma) check(std::isfinite(s) && s >= 0.0, "noise_sigma must be finite and >= 0");
  check(o.chip_probability >= 0.0 && o.chip_probability <= 1.0, "chip_probability must be in [0, 1]");
  check(o.miss_probability >= 0.0 && o.miss_probability <= 1.0, "miss_probability must be in [0, 1]");
  check(std::isfinite(o.chip_min_um) && std::isfinite(o.chip_max_um) && o.chip_min_um <= o.chip_max_um,
        "chip_min_um must not exceed chip_max_um");
  check(o.chip_probability == 0.0 || !o.chip_directions.empty(), "chip_directions empty with chip_probability > 0");
  const auto n = static_cast<int>(o.noise_sigma.size());
  for (const ChipDirection& d : o.chip_directions) {
    check(!d.gains.empty(), "a chip direction moves no output");
    for (const auto& [output, gain] : d.gains)
      check(output >= 0 && output < n && std::isfinite(gain), "chip direction output index out of range");
  }
  check(std::isfinite(o.resolution) && o.resolution >= 0.0, "resolution must be finite and >= 0");
  check(!o.schedule.empty(), "schedule is empty");
  for (const ProbeInterval& p : o.schedule)
    check(std::isfinite(p.interval_s) && std::llround(p.interval_s) >= 1, "schedule interval_s must be >= 1 s");
}

}  // namespace

TwinProbe::TwinProbe(TwinProbeOptions options, std::uint64_t seed)
    : TwinProbe(std::move(options), common::SeededRandom(seed)) {}

TwinProbe::TwinProbe(TwinProbeOptions options, common::SeededRandom random)
    : options_(std::move(options)), random_(std::move(random)) {
  validate(options_);
}

bool TwinProbe::due(double t_s) const {
  const long long t = std::llround(t_s);
  for (const ProbeInterval& p : options_.schedule) {
    if (static_cast<double>(t) > p.until_s) continue;
    return t % std::llround(p.interval_s) == 0;
  }
  return false;  // after the last segment: no more cycles
}

Eigen::VectorXd TwinProbe::measure(const Eigen::VectorXd& truth) {
  const TwinProbeOptions& o = options_;
  const auto n = static_cast<Eigen::Index>(o.noise_sigma.size());
  if (truth.size() != n)
    throw std::invalid_argument("TwinProbe::measure: " + std::to_string(truth.size()) + " true errors for a probe of " +
                                std::to_string(n) + " outputs");
  Eigen::VectorXd measured = truth;
  const auto add_chip = [&](const ChipDirection& d, double size) {
    for (const auto& [output, gain] : d.gains) measured(output) += size * gain;
  };
  const auto direction_index = [&] {
    return static_cast<std::size_t>(random_.uniform() * static_cast<double>(o.chip_directions.size()));
  };

  if (o.chip_order == ChipOrder::kAfterNoise) {
    for (Eigen::Index e = 0; e < n; ++e) measured(e) += random_.normal(o.noise_sigma[static_cast<std::size_t>(e)]);
    if (random_.chance(o.chip_probability)) {
      ++chips_;
      double size = random_.uniform(o.chip_min_um, o.chip_max_um);
      if (o.chip_random_sign && !random_.chance(0.5)) size = -size;
      add_chip(o.chip_directions[direction_index()], size);
    }
  } else {
    const bool chip = random_.chance(o.chip_probability);
    // The direction is drawn on every cycle (as the recording's simulation always did).
    const std::size_t direction = o.chip_directions.empty() ? 0 : direction_index();
    double size = 0.0;
    for (Eigen::Index e = 0; e < n; ++e) {
      measured(e) += random_.normal(o.noise_sigma[static_cast<std::size_t>(e)]);
      if (chip && e == o.chip_directions[direction].gains.front().first) {
        size = random_.uniform(o.chip_min_um, o.chip_max_um);
        if (o.chip_random_sign && !random_.chance(0.5)) size = -size;
      }
    }
    if (chip) {
      ++chips_;
      add_chip(o.chip_directions[direction], size);
    }
  }
  if (o.resolution > 0.0)
    for (Eigen::Index e = 0; e < n; ++e) measured(e) = common::quantise(measured(e), o.resolution);
  return measured;
}

std::optional<Eigen::VectorXd> TwinProbe::cycle(const Eigen::VectorXd& truth) {
  if (options_.miss_probability > 0.0 && random_.chance(options_.miss_probability)) return std::nullopt;
  return measure(truth);
}

Eigen::MatrixXd TwinProbe::probe_run(const std::vector<double>& time_s, const Eigen::MatrixXd& truth) {
  if (truth.rows() != static_cast<Eigen::Index>(time_s.size()))
    throw std::invalid_argument("TwinProbe::probe_run: " + std::to_string(time_s.size()) + " times for " +
                                std::to_string(truth.rows()) + " rows of true errors");
  Eigen::MatrixXd measured =
      Eigen::MatrixXd::Constant(truth.rows(), truth.cols(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t k = 0; k < time_s.size(); ++k) {
    const auto r = static_cast<Eigen::Index>(k);
    if (!due(time_s[k])) continue;
    if (const auto reading = cycle(truth.row(r).transpose())) measured.row(r) = reading->transpose();
  }
  return measured;
}

}  // namespace alc::probing
