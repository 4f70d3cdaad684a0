#pragma once
// The supervisor's read-only status page ([status] in the config; off without it): the state, the
// last day (machine time) of probe measurements, predictions, probe requests and axis offsets as
// inline SVG charts (report/'s chart writer), and the latest events. Self-contained: no network, one
// small script (the report's DOM check). Served over HTTP by cpp-httplib (GET only, bounded).
#include <cstddef>
#include <deque>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "supervisor/config.hpp"

namespace alc::supervisor {

// What the page shows, fed by the supervisor's thread with what it publishes and the probe results it
// accepted; read by the server's threads. Bounded: only the window (machine time) before the latest
// time seen is kept, and at most kMaxPoints per series.
class StatusModel {
 public:
  static constexpr std::size_t kMaxPoints = 20000;
  static constexpr std::size_t kMaxEvents = 30;
  StatusModel(std::string machine_id, std::vector<std::string> outputs, double window_s);

  // A message the supervisor published on PREFIX/<topic> ("state", "offsets", "probe/request", "event").
  void published(const std::string& topic, const std::string& payload);
  // A probe result (PREFIX/probe/result) the supervisor accepted.
  void probe_result(const std::string& payload);

  std::string html() const;        // the page
  std::string state_json() const;  // the latest state message ("{}" before the first)
  std::size_t points() const;      // stored points of every series (for the tests)

 private:
  struct Row {
    double t = 0.0;
    std::vector<double> v;
  };
  void seen(double t);
  void prune();

  std::string machine_id_;
  std::vector<std::string> outputs_;
  double window_s_;
  mutable std::mutex mutex_;
  std::string state_ = "{}";
  double latest_s_ = -std::numeric_limits<double>::infinity();
  std::deque<Row> measured_, predicted_, axis_;
  std::vector<std::string> axis_names_;
  std::deque<std::pair<double, long long>> requests_;  // due time, id
  std::deque<std::string> events_;
};

// The HTTP server of the page on config.host:config.port, in a thread of its own: GET / (the page) and
// GET /state.json; anything else 404 (405 for another method). Throws std::runtime_error naming the
// address when it cannot listen.
class StatusServer {
 public:
  StatusServer(const StatusConfig& config, const StatusModel& model);
  ~StatusServer();
  StatusServer(const StatusServer&) = delete;
  StatusServer& operator=(const StatusServer&) = delete;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace alc::supervisor
