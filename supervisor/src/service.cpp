#include "supervisor/service.hpp"

#include <mosquitto.h>

#include <chrono>
#include <fstream>
#include <map>
#include <thread>

#include "common/log.hpp"
#include "supervisor/status_page.hpp"
#include "supervisor/supervisor.hpp"

namespace alc::supervisor {

namespace {

std::shared_ptr<spdlog::logger> logger() { return log::get("supervisor"); }

double wall_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string password_of(const SupervisorConfig& c) {
  std::ifstream in(*c.mqtt.password_file);
  std::string line;
  if (!in || !std::getline(in, line) || line.empty())
    throw ConfigError(c.file.string(), "mqtt.password_file", "\"" + c.mqtt.password_file->string() + "\"",
                      "cannot be read or its first line is empty");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return line;
}

// libmosquitto, driven from this thread (mosquitto_loop): callbacks run inside loop().
//
// Acknowledged after the journal: libmosquitto answers a QoS 1 PUBLISH with its PUBACK before it calls
// on_message, and without threaded mode it writes that PUBACK to the socket at once, so a kill -9
// between it and the inbox commit lost the message (the broker had it acknowledged). In threaded mode
// (mosquitto_threaded_set; no thread is started, this one still drives every loop) a packet is only
// queued and written by the next mosquitto_loop, which runs after the callback has committed the
// message to the inbox: a kill before that leaves it unacknowledged and the broker sends it again.
class MqttBus : public Bus {
 public:
  MqttBus(const SupervisorConfig& c, const std::string& offline) : c_(c) {
    // The files of the config first, before there is a client to free on a refusal.
    const std::string pw = c.mqtt.username && c.mqtt.password_file ? password_of(c) : std::string();
    if (c.mqtt.tls_ca_file) {
      // libmosquitto says only "Invalid function arguments provided" for a CA file it cannot read.
      std::error_code ec;
      if (!std::filesystem::is_regular_file(*c.mqtt.tls_ca_file, ec) || !std::ifstream(*c.mqtt.tls_ca_file))
        throw ConfigError(c.file.string(), "mqtt.tls_ca_file", "\"" + c.mqtt.tls_ca_file->string() + "\"",
                          "cannot be read as a file (a CA certificate in PEM)");
    }
    mosquitto_lib_init();
    m_ = mosquitto_new(c.mqtt.client_id.c_str(), /*clean_session=*/false, this);
    if (!m_) {
      mosquitto_lib_cleanup();
      throw std::runtime_error("mqtt: cannot create a client");
    }
    try {
      configure(offline, pw);
    } catch (...) {  // the destructor does not run for a constructor that throws
      mosquitto_destroy(m_);
      mosquitto_lib_cleanup();
      throw;
    }
  }

  void configure(const std::string& offline, const std::string& pw) {
    const SupervisorConfig& c = c_;
    mosquitto_int_option(m_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V311);
    check(mosquitto_threaded_set(m_, true), "threaded_set");  // see the class comment
    if (c.mqtt.username)
      mosquitto_username_pw_set(m_, c.mqtt.username->c_str(), c.mqtt.password_file ? pw.c_str() : nullptr);
    if (c.mqtt.tls_ca_file)
      check(mosquitto_tls_set(m_, c.mqtt.tls_ca_file->c_str(), nullptr, nullptr, nullptr, nullptr), "tls_set");
    const std::string will_topic = c.mqtt.prefix + "/state";
    check(mosquitto_will_set(m_, will_topic.c_str(), static_cast<int>(offline.size()), offline.data(), 1, true),
          "will_set");
    mosquitto_connect_callback_set(m_, [](mosquitto*, void* self, int rc) { static_cast<MqttBus*>(self)->connected(rc); });
    mosquitto_disconnect_callback_set(m_, [](mosquitto*, void* self, int rc) {
      static_cast<MqttBus*>(self)->online_ = false;
      if (rc != 0) logger()->warn("mqtt: connection lost ({})", mosquitto_strerror(rc));
    });
    mosquitto_message_callback_set(m_, [](mosquitto*, void* self, const mosquitto_message* msg) {
      static_cast<MqttBus*>(self)->message(msg);
    });
    mosquitto_publish_callback_set(m_, [](mosquitto*, void* self, int) { --static_cast<MqttBus*>(self)->unacked_; });
    mosquitto_subscribe_callback_set(m_, [](mosquitto*, void* self, int mid, int count, const int* granted) {
      static_cast<MqttBus*>(self)->subscribed(mid, count, granted);
    });
    // libmosquitto names what failed (a TLS certificate, ...) only in its log: keep the latest error.
    mosquitto_log_callback_set(m_, [](mosquitto*, void* self, int level, const char* text) {
      if ((level & MOSQ_LOG_ERR) && text) static_cast<MqttBus*>(self)->last_error_ = text;
    });
  }
  ~MqttBus() override {
    mosquitto_destroy(m_);
    mosquitto_lib_cleanup();
  }

  void set_supervisor(Supervisor* s) { s_ = s; }
  void set_status(StatusModel* m) { status_ = m; }

  void publish(const std::string& topic, const std::string& payload, bool retained) override {
    const std::string t = c_.mqtt.prefix + "/" + topic;
    const int rc = mosquitto_publish(m_, nullptr, t.c_str(), static_cast<int>(payload.size()), payload.data(), 1, retained);
    if (status_) status_->published(topic, payload);
    if (rc == MOSQ_ERR_SUCCESS) ++unacked_;
    else logger()->warn("mqtt: publish on {} failed: {}", t, mosquitto_strerror(rc));
  }

  // Connects (TCP) and waits for the broker's answer; throws BrokerRefused on a refusal.
  bool connect(const std::atomic<bool>& stop) {
    refused_ = -1;
    last_error_.clear();
    const int rc = first_ ? mosquitto_connect(m_, c_.mqtt.host.c_str(), c_.mqtt.port, c_.mqtt.keepalive_s)
                          : mosquitto_reconnect(m_);
    // A TLS failure before the first connection is the configuration's (the CA does not check the
    // broker's certificate, or the broker speaks no TLS there): retrying would not help. Later ones
    // (the broker came back with another certificate) are retried like any connection loss.
    if (rc == MOSQ_ERR_TLS && !ever_connected_) tls_failed(rc);
    if (rc != MOSQ_ERR_SUCCESS) {
      logger()->warn("mqtt: cannot connect to {}:{}: {}", c_.mqtt.host, c_.mqtt.port, mosquitto_strerror(rc));
      return false;
    }
    first_ = false;
    while (!online_ && refused_ < 0 && !stop) {
      const int lrc = mosquitto_loop(m_, 100, 1);
      if (lrc == MOSQ_ERR_TLS && !ever_connected_) tls_failed(lrc);
      if (lrc != MOSQ_ERR_SUCCESS) break;
    }
    if (refused_ > 0)
      throw BrokerRefused("the broker " + c_.mqtt.host + ":" + std::to_string(c_.mqtt.port) +
                          " refused the connection: " + mosquitto_connack_string(refused_) +
                          (c_.mqtt.username ? " (user '" + *c_.mqtt.username + "')" : std::string(" (anonymous)")));
    return online_;
  }
  // One round of network I/O; false when the connection is gone. Throws BrokerRefused when the broker
  // refused a subscription (its ACL): the supervisor would wait for ever for messages that never come.
  bool loop(int timeout_ms) {
    const bool up = mosquitto_loop(m_, timeout_ms, 1) == MOSQ_ERR_SUCCESS && online_;
    if (!refused_topic_.empty())
      throw BrokerRefused("the broker " + c_.mqtt.host + ":" + std::to_string(c_.mqtt.port) +
                          " refused the subscription to " + refused_topic_ + " (not authorized: its ACL" +
                          (c_.mqtt.username ? " for user '" + *c_.mqtt.username + "'" : std::string(" for anonymous clients")) +
                          " does not grant that topic to read)");
    return up;
  }
  // Until every QoS 1 publish is acknowledged, at most `seconds`.
  void flush(double seconds) {
    pump(seconds, [this] { return unacked_ <= 0; });
  }
  // Queues the DISCONNECT and writes it (threaded mode writes in mosquitto_loop only), so the broker
  // sees a clean close and does not publish the will over the offline state just published.
  void disconnect() {
    if (mosquitto_disconnect(m_) == MOSQ_ERR_SUCCESS) pump(2.0, [] { return false; });  // until it is closed
  }
  bool online() const { return online_; }

 private:
  // Network rounds until done(), the connection is gone, or `seconds` have passed.
  template <class Done>
  void pump(double seconds, Done done) {
    const double end = wall_now() + seconds;
    while (!done() && wall_now() < end && mosquitto_loop(m_, 50, 1) == MOSQ_ERR_SUCCESS) {
    }
  }
  [[noreturn]] void tls_failed(int rc) const {
    throw BrokerRefused("TLS to the broker " + c_.mqtt.host + ":" + std::to_string(c_.mqtt.port) + " failed (" +
                        (last_error_.empty() ? std::string(mosquitto_strerror(rc)) : last_error_) + ")" +
                        (c_.mqtt.tls_ca_file ? " with mqtt.tls_ca_file \"" + c_.mqtt.tls_ca_file->string() + "\"" : ""));
  }
  static void check(int rc, const char* what) {
    if (rc != MOSQ_ERR_SUCCESS) throw std::runtime_error(std::string("mqtt: ") + what + ": " + mosquitto_strerror(rc));
  }
  void connected(int rc) {
    if (rc != 0) {
      refused_ = rc;
      return;
    }
    refused_ = 0;
    online_ = true;
    ever_connected_ = true;
    unacked_ = 0;
    subscriptions_.clear();
    for (const InboundTopic& t : kInboundTopics) {
      const std::string topic = c_.mqtt.prefix + "/" + t.name;
      int mid = 0;
      if (mosquitto_subscribe(m_, &mid, topic.c_str(), 1) == MOSQ_ERR_SUCCESS) subscriptions_[mid] = &t;
    }
    logger()->info("mqtt: connected to {}:{} as {}", c_.mqtt.host, c_.mqtt.port, c_.mqtt.client_id);
  }
  // The broker's answer to a subscription: 0x80 (MQTT 3.1.1) for a topic it refuses.
  void subscribed(int mid, int count, const int* granted) {
    for (int i = 0; i < count; ++i)
      if (granted[i] == 0x80 && refused_topic_.empty()) {
        const auto it = subscriptions_.find(mid);
        const InboundTopic* t = it != subscriptions_.end() ? it->second : nullptr;
        const std::string topic = t ? c_.mqtt.prefix + "/" + t->name : "a topic";
        // An optional topic (asking for a probe by hand): a broker that does not let it through costs that, no more.
        if (t && t->if_refused)
          logger()->warn("mqtt: the broker refused the subscription to {}: {}", topic, t->if_refused);
        else
          refused_topic_ = topic;
      }
  }
  void message(const mosquitto_message* msg) {
    if (!s_ || !msg->topic) return;
    const std::string topic(msg->topic);
    const std::string own = c_.mqtt.prefix + "/";
    if (topic.rfind(own, 0) != 0) return;
    const std::string payload(static_cast<const char*>(msg->payload), static_cast<std::size_t>(msg->payloadlen));
    const std::int64_t rejected = s_->counts().rejected;
    s_->on_message(topic.substr(own.size()), payload, wall_now());
    if (status_ && topic == own + "probe/result" && s_->counts().rejected == rejected) status_->probe_result(payload);
  }

  const SupervisorConfig& c_;
  mosquitto* m_ = nullptr;
  Supervisor* s_ = nullptr;
  StatusModel* status_ = nullptr;
  std::string last_error_;
  std::map<int, const InboundTopic*> subscriptions_;  // message id -> topic, of this connection's subscriptions
  std::string refused_topic_;                 // a subscription the broker refused
  bool ever_connected_ = false;
  bool first_ = true;
  bool online_ = false;
  int refused_ = -1;
  int unacked_ = 0;
};

}  // namespace

void run_service(const SupervisorConfig& config, const std::atomic<bool>& stop, const std::string& software_version) {
  const std::string offline = "{\"online\":false,\"machine_id\":\"" + config.machine_id + "\"}";
  MqttBus bus(config, offline);
  // The status page (only with [status]) sees what is published from here on, before the first
  // connection (the history's recovery publishes nothing).
  std::unique_ptr<StatusModel> status;
  if (config.status) {
    status = std::make_unique<StatusModel>(config.machine_id, config.signals.outputs, config.status->window_s);
    bus.set_status(status.get());
  }
  Supervisor supervisor(config, bus, software_version);
  bus.set_supervisor(&supervisor);
  if (status) status->published("state", supervisor.state_json(false));
  std::unique_ptr<StatusServer> server;
  if (config.status) server = std::make_unique<StatusServer>(*config.status, *status);
  double backoff_s = 0.5;
  while (!stop) {
    if (!bus.connect(stop)) {
      // Backoff before the next attempt, watching the stop flag.
      const double until = wall_now() + backoff_s;
      while (!stop && wall_now() < until) std::this_thread::sleep_for(std::chrono::milliseconds(50));
      backoff_s = std::min(backoff_s * 2.0, 30.0);
      continue;
    }
    backoff_s = 0.5;
    supervisor.announce();
    while (!stop && bus.loop(100)) supervisor.on_wall_clock(wall_now());
    if (!stop) logger()->warn("mqtt: disconnected; reconnecting");
  }
  logger()->info("stopping");
  if (bus.online()) {
    bus.publish("state", supervisor.state_json(false), true);
    bus.flush(5.0);
    bus.disconnect();
  }
  supervisor.stop();
}

}  // namespace alc::supervisor
