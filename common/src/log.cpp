#include "common/log.hpp"

#include <spdlog/sinks/base_sink.h>
#include <spdlog/sinks/dist_sink.h>
#include <spdlog/sinks/rotating_file_sink.h>
#include <spdlog/sinks/stdout_sinks.h>

#include <filesystem>
#include <map>
#include <unordered_set>
#include <mutex>
#include <stdexcept>
#include <system_error>
#include <utility>
#include <vector>

namespace alc::log {

namespace {

constexpr const char* kPattern = "[%Y-%m-%d %H:%M:%S.%e] [%l] [%n] %v";

// Passes a message on to the next sink unless, while on, its text was passed before (distinct_only).
class DistinctSink final : public spdlog::sinks::base_sink<std::mutex> {
 public:
  explicit DistinctSink(std::shared_ptr<spdlog::sinks::sink> next) : next_(std::move(next)) {}
  void switch_to(bool on) {
    const std::lock_guard lock(mutex_);
    on_ = on;
    seen_.clear();
    withheld_ = 0;
  }
  std::size_t withheld() {
    const std::lock_guard lock(mutex_);
    return withheld_;
  }

 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override {
    if (on_) {
      std::string text(msg.logger_name.data(), msg.logger_name.size());
      text += '\x1f';
      text += static_cast<char>('0' + static_cast<int>(msg.level));
      text.append(msg.payload.data(), msg.payload.size());
      if (seen_.count(text)) {
        ++withheld_;
        return;
      }
      if (seen_.size() < kDistinctTexts) seen_.insert(std::move(text));
    }
    next_->log(msg);
  }
  void flush_() override { next_->flush(); }

 private:
  std::shared_ptr<spdlog::sinks::sink> next_;
  bool on_ = false;
  std::unordered_set<std::string> seen_;
  std::size_t withheld_ = 0;
};

// Every component logger writes through the distinct filter to one distributing sink; configure()
// swaps what that feeds.
struct Registry {
  std::mutex mutex;
  std::shared_ptr<spdlog::sinks::dist_sink_mt> sink = std::make_shared<spdlog::sinks::dist_sink_mt>();
  std::shared_ptr<DistinctSink> filter = std::make_shared<DistinctSink>(sink);
  spdlog::level::level_enum level = spdlog::level::warn;
  Options options;  // of the last configure()
  std::map<std::string, std::shared_ptr<spdlog::logger>, std::less<>> loggers;

  Registry() {
    auto err = std::make_shared<spdlog::sinks::stderr_sink_mt>();
    err->set_pattern(kPattern);
    sink->set_sinks({err});
  }
};

Registry& registry() {
  static Registry r;
  return r;
}

std::shared_ptr<spdlog::sinks::sink> open_file_sink(const Options& options) {
  const std::filesystem::path path(options.file);
  const std::filesystem::path dir = path.parent_path();
  std::error_code ec;
  if (!dir.empty() && !std::filesystem::is_directory(dir, ec))
    throw std::runtime_error("log file '" + options.file + "': directory '" + dir.string() + "' does not exist");
  if (options.max_file_bytes == 0) throw std::runtime_error("log file '" + options.file + "': max_file_bytes is 0");
  try {
    return std::make_shared<spdlog::sinks::rotating_file_sink_mt>(options.file, options.max_file_bytes,
                                                                   options.max_files);
  } catch (const spdlog::spdlog_ex& e) {
    throw std::runtime_error("log file '" + options.file + "' cannot be opened: " + e.what());
  }
}

}  // namespace

void configure(const Options& options) {
  std::vector<std::shared_ptr<spdlog::sinks::sink>> sinks;
  if (options.to_stderr) sinks.push_back(std::make_shared<spdlog::sinks::stderr_sink_mt>());
  if (!options.file.empty()) sinks.push_back(open_file_sink(options));
  for (const auto& s : sinks) s->set_pattern(kPattern);

  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  r.sink->set_sinks(std::move(sinks));
  r.level = options.level;
  r.options = options;
  for (auto& [name, logger] : r.loggers) logger->set_level(options.level);
}

Options configured() {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  return r.options;
}

std::shared_ptr<spdlog::logger> get(const std::string& component) {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  if (const auto it = r.loggers.find(component); it != r.loggers.end()) return it->second;
  auto logger = std::make_shared<spdlog::logger>(component, r.filter);
  logger->set_level(r.level);
  logger->flush_on(spdlog::level::trace);  // lines are rare: every one reaches the file at once
  r.loggers.emplace(component, logger);
  return logger;
}

void distinct_only(bool on) { registry().filter->switch_to(on); }

std::size_t repeats_withheld() { return registry().filter->withheld(); }

std::optional<spdlog::level::level_enum> parse_level(std::string_view text) {
  static const std::pair<std::string_view, spdlog::level::level_enum> kLevels[] = {
      {"trace", spdlog::level::trace}, {"debug", spdlog::level::debug},       {"info", spdlog::level::info},
      {"warn", spdlog::level::warn},   {"error", spdlog::level::err},          {"critical", spdlog::level::critical},
      {"off", spdlog::level::off}};
  for (const auto& [name, level] : kLevels)
    if (text == name) return level;
  return std::nullopt;
}

}  // namespace alc::log
