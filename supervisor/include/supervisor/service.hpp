#pragma once
// `alc supervise`: the supervisor on a real MQTT broker (libmosquitto): connects (username and
// password file, TLS when configured, clean session off, QoS 1, the retained state as its will),
// feeds what arrives to the Supervisor, reconnects with backoff, stops cleanly when `stop` is set.
#include <atomic>
#include <stdexcept>
#include <string>

#include "supervisor/config.hpp"

namespace alc::supervisor {

// The broker refused the connection (credentials, authorization): retrying would not help.
class BrokerRefused : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Runs until `stop` is set; then publishes the state offline, flushes the history and returns.
// Throws BrokerRefused, ConfigError (password file), or std::runtime_error.
void run_service(const SupervisorConfig& config, const std::atomic<bool>& stop, const std::string& software_version);

}  // namespace alc::supervisor
