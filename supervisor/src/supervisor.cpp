#include "supervisor/supervisor.hpp"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "common/log.hpp"
#include "common/number_text.hpp"
#include "common/utf8.hpp"
#include "nc_interface/commands.hpp"
#include "probing/schedule.hpp"
#include "runtime/history_recorder.hpp"
#include "runtime/nc_emitter.hpp"
#include "runtime/run.hpp"
#include "runtime/run_state.hpp"
#include "storage/history_reader.hpp"
#include "supervisor/inbox.hpp"
#include "supervisor/nc_link.hpp"

namespace alc::supervisor {

using Json = nlohmann::json;

namespace {

// Samples held while a probe is outstanding, at most: probe_timeout_s bounds them in machine time, this
// in memory (samples 1 ms apart would otherwise pile up for the whole timeout).
constexpr std::size_t kMaxHeldSamples = 20000;

std::shared_ptr<spdlog::logger> logger() { return log::get("supervisor"); }

Json number_or_null(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

Json named(const std::vector<std::string>& names, const Eigen::VectorXd& v) {
  Json j = Json::object();
  for (std::size_t i = 0; i < names.size(); ++i)
    j[names[i]] = number_or_null(static_cast<Eigen::Index>(i) < v.size() ? v(static_cast<Eigen::Index>(i)) : NAN);
  return j;
}

// Infinite times as text in the supervisor's saved state (JSON has no infinity).
Json time_json(double v) { return std::isfinite(v) ? Json(v) : Json(v > 0 ? "inf" : "-inf"); }
double time_of(const Json& j) {
  if (j.is_string()) return j.get<std::string>() == "inf" ? kInf : -kInf;
  return j.get<double>();
}

}  // namespace

// Sees every cycle after the recorders and the NC observer: events out, offsets in force.
class Supervisor::Tap : public runtime::Observer {
 public:
  explicit Tap(Supervisor& s) : s_(s) {}
  void on_cycle(const runtime::Cycle& cycle) override {
    const ControllerOutput& out = cycle.out();
    s_.prediction_ = out.prediction;
    const nc::AxisOffsets in_force = s_.nc_->state().in_force;
    if (!same(in_force, last_in_force_)) {
      last_in_force_ = in_force;
      s_.offsets_changed_ = true;
      // What the offsets now in force cancel: the prediction of this moment, where an axis can.
      for (Eigen::Index i = 0; i < s_.compensation_.size(); ++i)
        s_.compensation_(i) = s_.cancellable_[static_cast<std::size_t>(i)] ? out.prediction(i) : 0.0;
      // Of it, what the gated offsets cancel (a step toward the target, part of it). With a sink that
      // delivers, on_nc_cycle does this after the delivery (the offsets may be rolled back); before, without
      // one, the full prediction was published and learned with while the axis held one max_step of it.
      if (!s_.link_ || !s_.link_->delivers())
        s_.compensation_ = s_.error_space_->compensation(in_force, s_.compensation_);
    }
    for (const ControllerEvent& e : out.events) {
      Json j = {{"type", std::string(to_string(e.type))}, {"time_s", e.time_s}, {"reason", e.reason}};
      if (e.type == ControllerEvent::Type::PhaseChange) {
        j["from"] = std::string(to_string(e.from));
        j["to"] = std::string(to_string(e.to));
      }
      if (e.type == ControllerEvent::Type::ProbeIntervalChange) j["interval_s"] = number_or_null(e.interval_s);
      if (e.type == ControllerEvent::Type::AclBreach || e.type == ControllerEvent::Type::Implausible ||
          e.type == ControllerEvent::Type::Guard) {
        j["output"] = e.output;
        j["value"] = e.value;
        j["limit"] = e.limit;
      }
      s_.event(std::move(j));
    }
    s_.on_nc_cycle();
  }
  nc::AxisOffsets last_in_force_;

 private:
  static bool same(const nc::AxisOffsets& a, const nc::AxisOffsets& b) {
    return a.x_mm == b.x_mm && a.y_mm == b.y_mm && a.z_mm == b.z_mm && a.a_deg == b.a_deg && a.b_deg == b.b_deg &&
           a.c_deg == b.c_deg;
  }
  Supervisor& s_;
};

Supervisor::Supervisor(const SupervisorConfig& config, Bus& bus, std::string software_version)
    : config_(config),
      bus_(bus),
      software_version_(std::move(software_version)),
      controller_(config.signals.inputs, config.signals.outputs, config.parameters),
      driver_(controller_) {
  const auto n = static_cast<Eigen::Index>(config.signals.outputs.size());
  compensation_ = Eigen::VectorXd::Zero(n);
  prediction_ = Eigen::VectorXd::Zero(n);
  // Which outputs an axis offset cancels at the reference pose: each alone, 1 µm or 1 µm/m.
  for (const auto& name : config.signals.outputs) {
    const int field = kinematics::location_error_field(name);
    bool can = false;
    if (field >= 0) {
      kinematics::LocationErrors e{};
      kinematics::set_location_error(e, field, 1.0);
      const auto c = kinematics::compensate(config.machine.chain, {}, e);
      can = c.converged && c.non_compensable_um_per_m < 1e-3;
    }
    cancellable_.push_back(can);
    // A typo (E_ZOT for E_Z0T) is predicted and published, but no axis offset ever carries it.
    if (field < 0 && config.nc.sink != "none")
      logger()->warn("output {} is not a location error of the C axis (E_X0C, E_Y0C, E_Z0T, E_R0T, E_A0C, E_B0C, "
                     "E_C0C): it is predicted, never compensated on the NC",
                     name);
  }
  if (config.nc.sink == "spool" && config.nc.spool_dir) {
    std::error_code ec;
    if (!std::filesystem::is_directory(*config.nc.spool_dir, ec))
      throw ConfigError(config.file.string(), "nc.spool_dir", "\"" + config.nc.spool_dir->string() + "\"",
                        "is not a directory (it is not created)");
  }
  if (config.nc.sink != "none" || config.nc.probe != "gateway") link_ = std::make_unique<NcLink>(config);
  error_space_ = std::make_unique<ErrorSpace>(config.machine.chain, config.signals.outputs, cancellable_);
  driver_.set_machine({config.machine.chain, {}});
  // The history's directory must be there: created, a typo in history.db would begin a new history
  // beside months of learning, without a word.
  if (const std::filesystem::path dir = config.history.db.parent_path(); !dir.empty()) {
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec))
      throw ConfigError(config.file.string(), "history.db", "\"" + config.history.db.string() + "\"",
                        "its directory '" + dir.string() + "' does not exist (it is not created)");
  }
  storage::WriterOptions w;
  w.durability = config.history.durability;
  writer_ = std::make_unique<storage::HistoryWriter>(config.history.db, w);
  inbox_ = std::make_unique<Inbox>(config.history.db.string() + ".inbox", config.history.durability);
  begin_or_resume();
  nc_held_ = nc_->state().in_force;  // until read back (sync_nc)
}

Supervisor::~Supervisor() {
  try {
    stop();
  } catch (const std::exception& e) {
    logger()->error("stopping: {}", e.what());
  }
}

void Supervisor::begin_or_resume() {
  storage::RunRecord record;
  record.source = run_source(config_.machine_id);
  Json identity = {{"parameters", runtime::canonical_parameters(config_.parameters, controller_.schedule().name())},
                   {"machine", config_.nc.machine ? config_.nc.machine->string() : std::string("built-in")}};
  record.config_json = identity.dump();
  record.software_version = software_version_;
  record.input_names = config_.signals.inputs;
  record.output_names = config_.signals.outputs;
  record.offset_names = runtime::HistoryRecorder::offset_names(config_.machine.chain, config_.signals.outputs);
  const bool unfinished =
      runtime::latest_unfinished_run(storage::HistoryReader(config_.history.db).runs(), record.source).has_value();
  const double every = config_.history.snapshot_every_s;
  if (unfinished)
    lifecycle_ = std::make_unique<runtime::RunLifecycle>(*writer_, config_.history.db, record, every,
                                                         runtime::RunLifecycle::Resume{});
  else
    lifecycle_ = std::make_unique<runtime::RunLifecycle>(*writer_, record, every);
  const storage::RunId run = lifecycle_->run();
  recorder_ = std::make_unique<runtime::HistoryRecorder>(*writer_, run, !record.offset_names.empty());
  runtime::NcObserverOptions nc_options = runtime::nc_observer_options(config_.machine);
  nc_options.dialect = config_.nc.dialect;
  nc_ = std::make_unique<runtime::NcCommandObserver>(config_.signals.outputs, nc_options);
  nc_->set_history({writer_.get(), run,
                    link_ && link_->delivers() ? link_->sink_name() : "mqtt:" + config_.mqtt.prefix + "/offsets",
                    config_.nc.dialect, config_.machine.nc});
  tap_ = std::make_unique<Tap>(*this);
  tap_->last_in_force_ = nc_->state().in_force;
  driver_.add(*recorder_);
  driver_.add(*nc_);
  driver_.add(*tap_);
  lifecycle_->set_encoder([this](std::int64_t) {
    inbox_->save_state(next_seq_, extras_json());  // before the snapshot that refers to it
    ++snapshots_;
    runtime::RunState s;
    s.next_index = next_seq_;
    s.controller = controller_.state();
    s.identification_s = driver_.identification_s();
    return runtime::encode_run_state(s);
  });
  if (!unfinished) {
    inbox_->clear();
    next_seq_ = inbox_->next_seq();
    lifecycle_->save_snapshot(controller_, 0);
    inbox_->prune(next_seq_);
    logger()->info("run {} begun in {}", run, config_.history.db.string());
    return;
  }
  const storage::ControllerSnapshot& snap = *lifecycle_->resumed_from();
  runtime::RunState s =
      runtime::load_run_state(config_.history.db, run, snap, config_.signals.inputs.size());
  controller_ = Controller(config_.signals.inputs, config_.signals.outputs, config_.parameters, std::move(s.controller));
  driver_.set_identification_s(s.identification_s);
  next_seq_ = s.next_index;
  const auto extras = inbox_->state_at(next_seq_);
  if (!extras)
    throw std::runtime_error(inbox_->path().string() + ": no supervisor state for the snapshot of run " +
                             std::to_string(run) + " (inbox entry " + std::to_string(next_seq_) + ")");
  restore_extras(*extras, snap.time_s);
  const nc::AxisOffsets at_snapshot = nc_->state().in_force;
  // Everything accepted after the snapshot, again, in the order it was accepted.
  recovering_ = true;
  const auto entries = inbox_->from(next_seq_);
  for (const InboxEntry& e : entries) process(e.kind, e.payload, e.seq);
  recovering_ = false;
  settle_nc_after_recovery(at_snapshot);
  logger()->info("run {} resumed from its snapshot at t = {} s and {} inbox entries after it", run, snap.time_s,
                 entries.size());
}

std::string Supervisor::extras_json() const {
  const auto st = nc_->state();
  return Json{{"next_id", next_id_},
              {"compensation", std::vector<double>(compensation_.data(), compensation_.data() + compensation_.size())},
              {"last_offsets_s", time_json(last_offsets_s_)},
              {"last_received_s", time_json(last_received_s_)},
              {"nc_last", offsets_json(st.last)},
              {"nc_in_force", offsets_json(st.in_force)},
              {"nc_behind", st.behind},
              {"nc_next_periodic_s", time_json(st.next_periodic_s)},
              {"nc_budget", {st.budget.x_mm, st.budget.y_mm, st.budget.z_mm, st.budget.a_deg, st.budget.b_deg,
                             st.budget.c_deg}},
              {"nc_budget_s", time_json(st.budget_s)},
              {"received", counts_.received},
              {"rejected", counts_.rejected},
              {"requests", counts_.requests},
              {"timeouts", counts_.timeouts}}
      .dump();
}

void Supervisor::restore_extras(const std::string& text, double snapshot_s) {
  const Json j = Json::parse(text);
  next_id_ = j.at("next_id").get<std::int64_t>();
  const auto comp = j.at("compensation").get<std::vector<double>>();
  for (std::size_t i = 0; i < comp.size() && static_cast<Eigen::Index>(i) < compensation_.size(); ++i)
    compensation_(static_cast<Eigen::Index>(i)) = comp[i];
  last_offsets_s_ = time_of(j.at("last_offsets_s"));
  last_received_s_ = time_of(j.at("last_received_s"));
  runtime::NcCommandObserver::State st;
  const int wo = config_.machine.work_offset;
  st.last = offsets_of(j.at("nc_last"), wo);
  st.in_force = offsets_of(j.at("nc_in_force"), wo);
  st.behind = j.at("nc_behind").get<bool>();
  st.next_periodic_s = time_of(j.at("nc_next_periodic_s"));
  // The rate limit's budget; a snapshot of a build before it has none: the budget starts empty at
  // the snapshot's time then (refilled from there, never a whole step at once after a restart).
  st.budget = {0, 0, 0, 0, 0, 0};
  st.budget_s = snapshot_s;
  if (j.contains("nc_budget")) {
    const auto b = j.at("nc_budget").get<std::vector<double>>();
    if (b.size() != 6) throw std::runtime_error("supervisor snapshot: nc_budget must have 6 values");
    st.budget = {b[0], b[1], b[2], b[3], b[4], b[5]};
    st.budget_s = time_of(j.at("nc_budget_s"));
  }
  nc_->restore(st);
  tap_->last_in_force_ = st.in_force;
  counts_.received = j.at("received").get<std::int64_t>();
  counts_.rejected = j.at("rejected").get<std::int64_t>();
  counts_.requests = j.at("requests").get<std::int64_t>();
  counts_.timeouts = j.at("timeouts").get<std::int64_t>();
  prediction_ = controller_.state().prediction.size() ? controller_.state().prediction : prediction_;
}

void Supervisor::publish(const std::string& topic, const std::string& payload, bool retained) {
  if (!recovering_) bus_.publish(topic, payload, retained);
}

void Supervisor::event(Json e) {
  publish("event", e.dump(-1, ' ', false, Json::error_handler_t::replace), false);
}

void Supervisor::reject(const std::string& topic, const std::string& why) {
  ++counts_.rejected;
  // The reason may quote the peer's bytes (a Latin-1 input name): as valid UTF-8 (\xNN) for the log and
  // the event, whose JSON text could not be written otherwise.
  const std::string reason = common::valid_utf8(why);
  logger()->warn("message on {} rejected: {}", topic, reason);
  event({{"type", "MessageRejected"}, {"topic", topic}, {"reason", reason}});
}

void Supervisor::on_message(const std::string& topic, const std::string& payload, double wall_s) {
  if (stopped_) return;
  if (payload.size() > config_.mqtt.max_payload_bytes) {
    reject(topic, "payload of " + std::to_string(payload.size()) + " bytes is larger than max_payload_bytes = " +
                      std::to_string(config_.mqtt.max_payload_bytes));
    return;
  }
  if (std::none_of(kInboundTopics.begin(), kInboundTopics.end(), [&](const InboundTopic& t) { return topic == t.name; })) {
    reject(topic, "not a topic the supervisor reads");
    return publish("state", state_json(true), true);
  }
  const std::int64_t before = counts_.received;
  process(topic, payload, -1);
  after_message_nc();
  if (counts_.received != before) {
    last_sample_wall_s_ = wall_s;
    if (stale_) {
      stale_ = false;
      event({{"type", "SamplesResumed"}, {"reason", "a sample arrived"}});
    }
  }
  publish("state", state_json(true), true);
}

void Supervisor::on_wall_clock(double wall_s) {
  if (last_sample_wall_s_ == 0.0) last_sample_wall_s_ = wall_s;
  if (stale_ || wall_s - last_sample_wall_s_ < config_.signals.stale_after_s) return;
  stale_ = true;
  logger()->warn("no sample for {} s: stale, offsets held",
                 common::shortest_text(std::round((wall_s - last_sample_wall_s_) * 10.0) / 10.0));
  event({{"type", "Stale"},
         {"reason", "no sample for stale_after_s = " + common::shortest_text(config_.signals.stale_after_s) +
                        " s of wall-clock time: offsets held"}});
  publish("state", state_json(true), true);
}

// seq: the inbox entry being processed again (recovery), or -1 for a message just received.
void Supervisor::process(const std::string& topic, const std::string& payload, std::int64_t seq) {
  // "sample/jump": a journaled sample that jumped ahead (recovery), held again as it was.
  if (topic == "sample" || topic == "sample/jump") {
    auto parsed = parse_sample(payload, config_.signals.inputs);
    if (auto* r = std::get_if<Refusal>(&parsed)) return reject(topic, r->reason);
    const SampleMessage& m = std::get<SampleMessage>(parsed);
    // What the controller would refuse in the sample itself (an input beyond its plausible limit) is
    // refused here, before the journal: a rejected sample changes nothing, not even the latest time.
    if (const std::string why = controller_.sample_problem(m.time_s, m.inputs); !why.empty()) return reject(topic, why);
    if (m.time_s == last_received_s_)
      return reject(topic, "duplicate sample: time_s = " + common::shortest_text(m.time_s) + " s was accepted already");
    // A jump ahead by more than max_gap_s counts once the next sample confirms it (journaled "sample"
    // entries, seq >= 0, were accepted already). The sample after a jump that does not confirm it sets
    // it aside.
    const double gap = config_.signals.max_gap_s;
    if (jump_) {
      const Jump held = std::move(*jump_);
      jump_.reset();
      if (m.time_s > held.sample.time_s && m.time_s <= held.sample.time_s + gap) {
        accept_sample(held.sample, held.payload, held.seq);  // its inbox entry is the one it came with
      } else {
        reject("sample", "time jumps ahead to time_s = " + common::shortest_text(held.sample.time_s) + " s from " +
                             common::shortest_text(last_received_s_) + " s and the next sample (time_s = " +
                             common::shortest_text(m.time_s) + " s) does not confirm it: set aside");
      }
    }
    if (m.time_s < last_received_s_)
      return reject(topic, "time goes backwards: time_s = " + common::shortest_text(m.time_s) + " s after " +
                               common::shortest_text(last_received_s_) + " s");
    if ((seq < 0 || topic == "sample/jump") && std::isfinite(last_received_s_) && m.time_s > last_received_s_ + gap) {
      // Journaled now, so that a kill before the next sample loses nothing the broker was told is taken.
      jump_ = Jump{m, payload, seq >= 0 ? seq : inbox_->append("sample/jump", payload)};
      event({{"type", "TimeJump"},
             {"time_s", m.time_s},
             {"reason", "time jumps ahead by " + common::shortest_text(m.time_s - last_received_s_) +
                            " s, more than signals.max_gap_s = " + common::shortest_text(gap) +
                            " s: held until the next sample confirms it"}});
      return;
    }
    return accept_sample(m, payload, seq);
  }
  if (topic == "probe/result") {
    auto parsed = parse_probe_result(payload, config_.signals.outputs);
    if (auto* r = std::get_if<Refusal>(&parsed)) return reject(topic, r->reason);
    const ProbeResultMessage& m = std::get<ProbeResultMessage>(parsed);
    if (!outstanding_ || m.id != outstanding_->id || result_) {
      if (m.id >= next_id_ || m.id < 1) return reject(topic, "unknown probe id " + std::to_string(m.id));
      return reject(topic, "duplicate or late result for probe id " + std::to_string(m.id) +
                               " (answered or timed out already)");
    }
    if (m.time_s < outstanding_->trigger_s)
      return reject(topic, "probe " + std::to_string(m.id) + ": time_s = " + common::shortest_text(m.time_s) +
                               " s is before its request at " + common::shortest_text(outstanding_->trigger_s) +
                               " s (the request's requested_s)");
    // A result measured after the probe would have timed out is no answer to it (a time of 1e12 would
    // hold every later sample for ever, waiting for the machine time to reach it).
    if (m.time_s > outstanding_->asked_s + config_.signals.probe_timeout_s)
      return reject(topic, "probe " + std::to_string(m.id) + ": time_s = " + common::shortest_text(m.time_s) +
                               " s is after its timeout at " +
                               common::shortest_text(outstanding_->asked_s + config_.signals.probe_timeout_s) +
                               " s (the request's timeout_s)");
    const std::int64_t s = seq >= 0 ? seq : inbox_->append(topic, payload);
    entry_seq_ = s;
    result_ = m;
    drain();
    if (idle()) next_seq_ = entry_seq_ + 1;
    return;
  }
  if (topic == "probe/now") {
    auto parsed = parse_probe_now(payload);
    if (auto* r = std::get_if<Refusal>(&parsed)) return reject(topic, r->reason);
    // Before the first sample there is no model to judge and no machine time; the first probe of CP
    // comes with the first sample anyway.
    if (!controller_.state().started && held_.empty())
      return reject(topic, "no sample has been received yet: the first sample starts CP with a probe");
    if (asked_) return reject(topic, "a probe asked for on probe/now waits already (" + *asked_ + ")");
    entry_seq_ = seq >= 0 ? seq : inbox_->append(topic, payload);
    // Taken at the next sample fed (feed), never at once: a restart processes the journal again from
    // the latest snapshot, and a request acted on at the snapshot's own sample would be acted on at
    // another one then (the driver knows no sample before the first fed after a restart). Not idle()
    // while it waits: no snapshot or prune passes this entry.
    asked_ = common::valid_utf8(std::get<ProbeNowMessage>(parsed).reason);
    logger()->info("probe asked for on probe/now: {}", *asked_);
    return;
  }
  if (topic == "nc/compensation") return apply_probe_compensation(payload);  // journaled, see supervisor_nc.cpp
  if (topic == "nc/sending" && seq >= 0) {  // journaled (never from the broker), see settle_nc_after_recovery
    entry_seq_ = seq;
    nc_sending_ = payload;
    if (idle()) next_seq_ = seq + 1;
    return;
  }
  reject(topic, "not a topic the supervisor reads");
}

void Supervisor::accept_sample(const SampleMessage& m, const std::string& payload, std::int64_t seq) {
  const std::int64_t s = seq >= 0 ? seq : inbox_->append("sample", payload);
  entry_seq_ = s;
  last_received_s_ = m.time_s;
  ++counts_.received;
  held_.push_back(m);
  drain();
  if (idle()) next_seq_ = entry_seq_ + 1;  // entry_seq_: this sample's, or a delivery journaled while fed
}

void Supervisor::drain() {
  for (;;) {
    if (outstanding_) {
      if (result_ && last_received_s_ >= result_->time_s) {
        apply_result();
        continue;
      }
      const bool late = !held_.empty() && held_.back().time_s > outstanding_->asked_s + config_.signals.probe_timeout_s;
      const bool full = held_.size() >= kMaxHeldSamples;  // samples far denser than their clock says
      if (!result_ && (late || full)) {
        ++counts_.timeouts;
        logger()->warn("probe {} timed out", outstanding_->id);
        event({{"type", "ProbeTimeout"},
               {"id", outstanding_->id},
               {"time_s", held_.back().time_s},
               {"reason", late ? "no result within probe_timeout_s = " +
                                     common::shortest_text(config_.signals.probe_timeout_s) +
                                     " s of machine time after the request"
                               : "no result while " + std::to_string(held_.size()) + " samples were held"}});
        outstanding_.reset();
        after_timeout_ = true;
        continue;
      }
      return;
    }
    if (held_.empty()) {
      after_timeout_ = false;
      return;
    }
    const SampleMessage m = held_.front();
    held_.pop_front();
    feed(m);
  }
}

void Supervisor::feed(const SampleMessage& m) {
  runtime::Sample s;
  s.index = controller_.state().samples;
  s.time_s = m.time_s;
  s.inputs = m.inputs;
  offsets_changed_ = false;
  const ControllerOutput out = driver_.sample(s);
  if (!out.accepted) return reject("sample", out.reason);
  if (offsets_changed_ || m.time_s >= last_offsets_s_ + 900.0) publish_offsets(m.time_s);
  // A probe asked for (probe/now): due at the first sample fed without a probe outstanding.
  if (asked_ && !outstanding_) {
    driver_.request(m.time_s, *asked_);
    asked_.reset();
  }
  // After a timeout the probe is asked for again at the latest sample received, not at a held one of
  // the backlog: the request's timeout counts from the latest sample, so asking at the first held
  // sample would hold the rest again and release one sample per timeout. (Held samples after a result
  // ask at the sample that reaches the due time, as a replay does.)
  if (!outstanding_ && !(after_timeout_ && !held_.empty()) && probing::reached(m.time_s, controller_.state().next_probe_due_s))
    request_probe(m.time_s);
  if (!outstanding_ && held_.empty() && !jump_) {
    // A consistent point: every inbox entry up to this one is processed. Not while a sample far ahead
    // waits for the next (its entry, older than a probe result that drained the held samples, would be
    // pruned with the rest: the snapshot does not hold it).
    next_seq_ = entry_seq_ + 1;
    const std::int64_t before = snapshots_;
    lifecycle_->on_sample_done(s, controller_, controller_.state().samples);
    if (snapshots_ != before) {
      inbox_->prune(next_seq_);
      prune_history(m.time_s);
    }
    nc_->forget_commands();
    nc_sent_ = 0;
  }
}

void Supervisor::prune_history(double now_s) {
  if (!(config_.history.keep_s > 0.0)) return;
  const ControllerState& c = controller_.state();
  // Never a sample the controller's learning holds (a resume reads them back from the history).
  double before_s = now_s - config_.history.keep_s;
  if (!c.history.time_s.empty()) before_s = std::min(before_s, c.history.time_s.front());
  if (before_s <= pruned_before_s_) return;
  const std::int64_t deleted = writer_->prune_samples(lifecycle_->run(), c.history_first_index, before_s);
  pruned_before_s_ = before_s;
  if (deleted > 0)
    logger()->info("history: {} input samples and predictions before t = {} s deleted (keep_days = {})", deleted,
                   before_s, config_.history.keep_s / 86400.0);
}

void Supervisor::request_probe(double trigger_s) {
  // Asked now, when the latest sample received is last_received_s_ (later than trigger_s while held
  // samples are fed after a timeout): the timeout counts from then, not from a sample long past.
  after_timeout_ = false;
  outstanding_ = Outstanding{next_id_++, controller_.state().next_probe_due_s, trigger_s,
                             std::max(trigger_s, last_received_s_), compensation_};
  ++counts_.requests;
  publish_request();
}

void Supervisor::publish_request() {
  if (config_.nc.probe == "linuxcnc") return;  // the supervisor runs the probe cycle itself
  // due_s is when the schedule wanted the probe; the result's time_s must lie in [requested_s, timeout_s]
  // (a gateway sampling more sparsely than the probe interval, or a probe asked again after a timeout,
  // has requested_s after due_s).
  publish("probe/request", Json{{"id", outstanding_->id},
                                {"due_s", outstanding_->due_s},
                                {"requested_s", outstanding_->trigger_s},
                                {"timeout_s", outstanding_->asked_s + config_.signals.probe_timeout_s},
                                {"phase", std::string(to_string(controller_.phase()))}}
                               .dump(),
          false);
}

void Supervisor::apply_result() {
  // The held samples up to the probe's time, then the probe, then (drain) the rest.
  while (!held_.empty() && held_.front().time_s <= result_->time_s) {
    const SampleMessage m = held_.front();
    held_.pop_front();
    feed(m);
  }
  ProbeMeasurement p;
  p.time_s = result_->time_s;
  p.measured = result_->measured;
  p.compensation = outstanding_->compensation;  // what the NC held when the probe cycle was asked for
  const std::int64_t id = result_->id;
  outstanding_.reset();
  result_.reset();
  offsets_changed_ = false;
  const ControllerOutput out = driver_.probe(p);
  if (!out.accepted) return reject("probe/result", "probe " + std::to_string(id) + ": " + out.reason);
  if (offsets_changed_) publish_offsets(p.time_s);
}

void Supervisor::publish_offsets(double time_s) {
  last_offsets_s_ = time_s;
  const int wo = config_.machine.work_offset;
  publish("offsets",
          Json{{"time_s", time_s},
               {"prediction", named(config_.signals.outputs, prediction_)},
               {"compensation", named(config_.signals.outputs, compensation_)},
               {"axis", offsets_json(nc_->state().in_force)},
               {"work_offset", "G5" + std::to_string(3 + wo)}}
              .dump(),
          false);
}

std::string Supervisor::state_json(bool online) const {
  const ControllerState& c = controller_.state();
  return Json{{"online", online},
              {"machine_id", config_.machine_id},
              {"phase", std::string(to_string(c.phase))},
              {"model_age_s", c.has_model && std::isfinite(c.last_update_s) ? Json(c.now_s - c.last_update_s) : Json()},
              {"last_sample_s", c.started ? Json(c.now_s) : Json()},
              {"probe_interval_s", number_or_null(c.current_interval_s)},
              {"samples", c.samples},
              {"received", counts_.received},
              {"held", held_.size()},
              {"probes", c.probe_cycles},
              {"probe_requests", counts_.requests},
              {"probe_timeouts", counts_.timeouts},
              {"outstanding_probe", outstanding_ ? Json(outstanding_->id) : Json()},
              {"probe_asked", asked_ ? Json(*asked_) : Json()},
              {"rejected", counts_.rejected},
              {"stale", stale_}}
      .dump();
}

void Supervisor::announce() {
  publish("state", state_json(true), true);
  if (link_ && !nc_synced_) sync_nc(true);
  if (controller_.state().started) publish_offsets(controller_.state().now_s);
  if (outstanding_) publish_request();
  after_message_nc();
}

void Supervisor::stop() {
  if (stopped_) return;
  stopped_ = true;
  if (idle()) {
    lifecycle_->save_snapshot(controller_, controller_.state().samples);
    inbox_->prune(next_seq_);
  }
  lifecycle_->end(false);
  writer_->close();
  logger()->info("stopped: {} samples, {} probes", controller_.state().samples, controller_.state().probe_cycles);
}

}  // namespace alc::supervisor
