#include "supervisor/status_page.hpp"

#include <chrono>

#include <httplib.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <thread>

#include "common/log.hpp"
#include "report/html_report.hpp"
#include "report/svg_chart.hpp"

namespace alc::supervisor {

namespace {

using Json = nlohmann::json;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

const char* const kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"};

double number_or_nan(const Json& j) { return j.is_number() ? j.get<double>() : kNaN; }

// A JSON object's numbers for `names`, NaN where absent or null.
std::vector<double> values_of(const Json& object, const std::vector<std::string>& names) {
  std::vector<double> v;
  for (const auto& n : names) v.push_back(object.is_object() && object.contains(n) ? number_or_nan(object[n]) : kNaN);
  return v;
}

std::string fmt(double v) {
  if (!std::isfinite(v)) return "–";
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

}  // namespace

StatusModel::StatusModel(std::string machine_id, std::vector<std::string> outputs, double window_s)
    : machine_id_(std::move(machine_id)), outputs_(std::move(outputs)), window_s_(window_s) {}

void StatusModel::seen(double t) {
  if (std::isfinite(t) && t > latest_s_) latest_s_ = t;
}

void StatusModel::prune() {
  const double from = latest_s_ - window_s_;
  for (auto* d : {&measured_, &predicted_, &axis_})
    while (!d->empty() && (d->front().t < from || d->size() > kMaxPoints)) d->pop_front();
  while (!requests_.empty() && (requests_.front().first < from || requests_.size() > kMaxPoints)) requests_.pop_front();
  while (events_.size() > kMaxEvents) events_.pop_front();
}

void StatusModel::published(const std::string& topic, const std::string& payload) {
  std::lock_guard lock(mutex_);
  if (topic == "state") {
    state_ = payload;
    return;
  }
  const Json j = Json::parse(payload, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return;
  if (topic == "event") {
    events_.push_back(payload);
  } else if (topic == "probe/request") {
    const double due = number_or_nan(j.value("due_s", Json()));
    seen(due);
    requests_.emplace_back(due, j.value("id", 0LL));
  } else if (topic == "offsets") {
    const double t = number_or_nan(j.value("time_s", Json()));
    if (!std::isfinite(t)) return;
    seen(t);
    predicted_.push_back({t, values_of(j.value("prediction", Json()), outputs_)});
    const Json axis = j.value("axis", Json::object());
    if (axis_names_.empty() && axis.is_object())
      for (const auto& [k, v] : axis.items()) axis_names_.push_back(k);
    axis_.push_back({t, values_of(axis, axis_names_)});
  }
  prune();
}

void StatusModel::probe_result(const std::string& payload) {
  const Json j = Json::parse(payload, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return;
  const double t = number_or_nan(j.value("time_s", Json()));
  if (!std::isfinite(t)) return;
  std::lock_guard lock(mutex_);
  seen(t);
  measured_.push_back({t, values_of(j.value("errors", Json()), outputs_)});
  prune();
}

std::string StatusModel::state_json() const {
  std::lock_guard lock(mutex_);
  return state_;
}

std::size_t StatusModel::points() const {
  std::lock_guard lock(mutex_);
  return measured_.size() + predicted_.size() + axis_.size() + requests_.size();
}

std::string StatusModel::html() const {
  using report::escape_xml;
  std::lock_guard lock(mutex_);
  const double to_h = 1.0 / 3600.0;
  // One series per name over rows, x in hours of machine time, y scaled.
  auto series = [&](const std::deque<Row>& rows, const std::vector<std::string>& names, report::Series::Style style,
                    auto scale) {
    std::vector<report::Series> out;
    for (std::size_t k = 0; k < names.size(); ++k) {
      report::Series s;
      s.name = names[k];
      s.color = kColors[k % std::size(kColors)];
      s.style = style;
      for (const Row& r : rows) {
        s.x.push_back(r.t * to_h);
        s.y.push_back(r.v[k] * scale(names[k]));
      }
      out.push_back(std::move(s));
    }
    return out;
  };
  const auto one = [](const std::string&) { return 1.0; };
  std::vector<report::Marker> probes;
  for (const auto& [due, id] : requests_) probes.push_back({due * to_h, "sent", "probe request " + std::to_string(id)});
  std::optional<std::pair<double, double>> range;
  if (std::isfinite(latest_s_)) range = std::make_pair((latest_s_ - window_s_) * to_h, latest_s_ * to_h);

  std::vector<report::Chart> charts(3);
  charts[0].id = "measured";
  charts[0].title = "Probe measurements (with the compensation in force), probe requests as markers";
  charts[0].y_label = "error [µm, µm/m]";
  charts[0].series = series(measured_, outputs_, report::Series::Style::Points, one);
  charts[0].markers = probes;
  charts[1].id = "predicted";
  charts[1].title = "Predictions (at each offsets message)";
  charts[1].y_label = "prediction [µm, µm/m]";
  charts[1].series = series(predicted_, outputs_, report::Series::Style::Line, one);
  charts[1].markers = probes;
  charts[2].id = "offsets";
  charts[2].title = "Axis offsets after the safety gate";
  charts[2].y_label = "offset [µm, m°]";
  charts[2].series = series(axis_, axis_names_, report::Series::Style::Step, [](const std::string&) { return 1000.0; });
  for (auto& c : charts) {
    c.x_label = "machine time [h]";
    c.x_range = range;
  }

  std::string h = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>ALC " +
                  escape_xml(machine_id_) + "</title>\n<style>" + report::page_style() +
                  "</style>\n</head>\n<body>\n<header><h1>ALC supervisor: " + escape_xml(machine_id_) +
                  "</h1><p class=\"meta\">Read-only; the last " + fmt(window_s_ / 3600.0) +
                  " h of machine time. Reload for the latest.</p></header>\n<h2>State</h2>\n<table>\n";
  const Json state = Json::parse(state_, nullptr, false);
  if (state.is_object())
    for (const auto& [k, v] : state.items())
      h += "<tr><td>" + escape_xml(k) + "</td><td>" + escape_xml(v.is_string() ? v.get<std::string>() : v.dump()) +
           "</td></tr>\n";
  h += "</table>\n<h2>Last day</h2>\n";
  for (const auto& c : charts) {
    h += "<figure class=\"chart\" id=\"" + c.id + "\">";
    if (c.series.empty() || c.series.front().x.empty())
      h += "<p class=\"note\">" + escape_xml(c.title) + ": nothing yet.</p>";
    else
      h += report::render_svg(c);
    h += "</figure>\n";
  }
  h += "<h2>Latest events</h2>\n<table>\n";
  for (auto it = events_.rbegin(); it != events_.rend(); ++it) h += "<tr><td>" + escape_xml(*it) + "</td></tr>\n";
  h += "</table>\n<pre id=\"alc-dom-check\"></pre>\n";
  h += report::dom_check_script();
  h += "</body>\n</html>\n";
  return h;
}

struct StatusServer::Impl {
  httplib::Server server;
  std::thread thread;
};

StatusServer::StatusServer(const StatusConfig& config, const StatusModel& model) : impl_(std::make_unique<Impl>()) {
  auto& s = impl_->server;
  // Bounded: a few worker threads, short timeouts, no request body, small headers (httplib's limits).
  s.new_task_queue = [] { return new httplib::ThreadPool(2); };
  s.set_read_timeout(5, 0);
  s.set_write_timeout(5, 0);
  s.set_keep_alive_max_count(10);
  s.set_payload_max_length(1024);
  const auto headers = [](httplib::Response& res) {
    res.set_header("Content-Security-Policy",
                   "default-src 'none'; style-src 'unsafe-inline'; script-src 'unsafe-inline'; img-src data:");
    res.set_header("Cache-Control", "no-store");
    res.set_header("X-Content-Type-Options", "nosniff");
  };
  s.Get("/", [&model, headers](const httplib::Request&, httplib::Response& res) {
    headers(res);
    res.set_content(model.html(), "text/html; charset=utf-8");
  });
  s.Get("/state.json", [&model, headers](const httplib::Request&, httplib::Response& res) {
    headers(res);
    res.set_content(model.state_json(), "application/json");
  });
  const auto refuse = [](const httplib::Request&, httplib::Response& res) {
    res.status = 405;
    res.set_header("Allow", "GET");
  };
  s.Post(".*", refuse);
  s.Put(".*", refuse);
  s.Delete(".*", refuse);
  s.Patch(".*", refuse);
  s.Options(".*", refuse);
  // SO_REUSEADDR only (a restart binds again at once while old connections linger in TIME_WAIT), not
  // cpp-httplib's default SO_REUSEPORT, with which a second supervisor bound the same port without a
  // word and the kernel spread the requests over both: another machine's state, at random.
  s.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, reinterpret_cast<void*>(&yes), sizeof(yes));
  });
  // An IPv6 address in brackets before the port, as in a URL and in the config's `listen`.
  const std::string where = (config.host.find(':') == std::string::npos ? config.host : "[" + config.host + "]") +
                            ":" + std::to_string(config.port);
  if (!s.bind_to_port(config.host, config.port))
    throw std::runtime_error("status page: cannot listen on " + where + " (key status.listen)");
  impl_->thread = std::thread([this] { impl_->server.listen_after_bind(); });
  // Until its thread listens: cpp-httplib's stop() does nothing before that, and a supervisor stopped
  // at once (the broker refusing it) then waited for ever in the destructor's join.
  for (int i = 0; i < 5000 && !impl_->server.is_running(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  log::get("supervisor")->info("status page on http://{}/", where);
}

StatusServer::~StatusServer() {
  impl_->server.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

}  // namespace alc::supervisor
