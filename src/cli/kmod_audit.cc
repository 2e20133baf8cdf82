// `contego kmod audit --policy FILE --audit LOG`: the reader of contego.ko's
// audit ring (/dev/contego-audit, docs/kernel-client.md "Audit"). Each record
// the module took becomes a line of the hash-chained audit log (the same
// writer and format as `contego monitor`, names from the policy); records are
// acknowledged to the module only once their lines are in the log, so a
// reader that dies or cannot write loses nothing: the module keeps them for
// the next reader, and while no reader takes records it fails every call
// closed. SIGINT/SIGTERM: stop after what has been read; SIGHUP: reopen (or
// rotate) the log, as the monitor does.
#include "cli/kmod_audit.h"

#include <fcntl.h>
#include <poll.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstddef>
#include <cstring>
#include <fmt/core.h>
#include <linux/contego_kmod.h>
#include <sys/ioctl.h>
#include <sys/signalfd.h>

#include "contego/core_c.h"
#include "contego/i2c_plan.h"

#include "base/clock.h"
#include "base/unique_fd.h"
#include "bus/smbus_plan.h"
#include "cli/kmod_status.h"
#include "cli/policy_load.h"
#include "cli/stop_signals.h"
#include "cli/trusted_setup.h"
#include "monitor/metrics.h"

namespace contego::cli {
namespace {

// The layout contego.ko writes (its BUILD_BUG_ON says the same).
static_assert(sizeof(contego_kmod_record) == 136);
static_assert(offsetof(contego_kmod_record, fields) == 56);

const char* safe_why(uint8_t why) {
  switch (why & ~CONTEGO_KMOD_SAFE_FAILED) {
    case CONTEGO_KMOD_SAFE_LOAD:
      return "policy loaded";
    case CONTEGO_KMOD_SAFE_UNRECORDED:
      return "an audit record could not be taken: failing closed";
    case CONTEGO_KMOD_SAFE_TRANSFER:
      return "fail-safe inside a transfer of several messages";
    case CONTEGO_KMOD_SAFE_UNLOAD:
      return "module unloading";
    case CONTEGO_KMOD_SAFE_EXIT:
      return "session ended";
    case CONTEGO_KMOD_SAFE_ADAPTER:
      return "its adapter came back";
    default:
      return "unknown reason";
  }
}

std::string hex(const uint8_t* bytes, uint32_t len) {
  std::string s;
  for (uint32_t i = 0; i < len; ++i) s += fmt::format("{}{:02x}", i ? " " : "", bytes[i]);
  return s;
}

uint64_t clock_us(clockid_t id) {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<uint64_t>(ts.tv_sec) * 1000000u + static_cast<uint64_t>(ts.tv_nsec) / 1000u;
}

// The record's task by the policy's name ("(unknown)" past the table).
const char* task_name(const monitor::NameTable& names, const contego_kmod_record& r) {
  return r.task < names.tasks.size() ? names.tasks[r.task].c_str() : "(unknown)";
}

std::string caller(const contego_kmod_record& r) {
  return r.pid == 0 ? std::string("module") : fmt::format("pid {} uid {}", r.pid, r.uid);
}

// A session's end (CONTEGO_KMOD_SAFE_EXIT): which task, which process, how it
// ended (`count` is its wait status), as the monitor's "task N exited".
std::string session_end(const monitor::NameTable& names, const contego_kmod_record& r) {
  const char* task = task_name(names, r);
  const uint32_t status = r.count;
  const std::string how = (status & 0x7f) != 0
                              ? fmt::format("killed by signal {}{}", status & 0x7f,
                                            (status & 0x80) ? " (core dumped)" : "")
                              : fmt::format("exited with status {}", (status >> 8) & 0xff);
  const std::string staged =
      r.field_count >= 1 && r.fields[0] > 0
          ? fmt::format(
                "; {} register write(s) it staged were never completed (their group's "
                "last register never came): they never reached the device",
                r.fields[0])
          : std::string();
  return fmt::format("task {} ({}) exited: pid {} uid {} {}{}{}", r.task, task, r.pid, r.uid, how,
                     r.index ? ", then its process group's leader exited" : "", staged);
}

}  // namespace

uint64_t decision_wall_us(uint64_t mono_us) {
  // The module's clock is CLOCK_MONOTONIC (ktime_get_ns): the same clock
  // user space reads. Its distance to now, taken off the wall clock now.
  const uint64_t mono_now = clock_us(CLOCK_MONOTONIC);
  const uint64_t wall_now = clock_us(CLOCK_REALTIME);
  const uint64_t ago = mono_now > mono_us ? mono_now - mono_us : 0;
  return wall_now > ago ? wall_now - ago : 0;
}

KmodNames::KmodNames(std::vector<Image> images)
    : images_(std::move(images)), current_(images_.empty() ? &none_ : &images_.front().names) {}

std::string KmodNames::follow(const contego_kmod_record& r) {
  if (r.type == CONTEGO_KMOD_REC_LOAD_REFUSED && r.reason == CONTEGO_KMOD_REFUSED_UNSAFE) {
    // An image withdrawn after its load record: its devices named, then
    // the names of the image in force again (fields[2]; none: no policy).
    const auto named = [&](int32_t mask) {
      std::string out;
      for (uint32_t d = 0; d < 32; ++d) {
        if ((static_cast<uint32_t>(mask) & (1u << d)) == 0) continue;
        out += fmt::format("{}{} ({})", out.empty() ? "" : ", ", d,
                           d < current_->devices.size() ? current_->devices[d] : "unknown");
      }
      return out;
    };
    std::string what;
    if (r.fields[1] != 0) what = "sensor(s) " + named(r.fields[1]) + " not read";
    if (r.fields[0] != 0) {
      what += fmt::format("{}safe state of device(s) {} not driven", what.empty() ? "" : ", ",
                          named(r.fields[0]));
    }
    if (r.field_count < 3) {
      current_ = &none_;
      return what + "; no policy is in force";
    }
    return what + "; the policy in force stays" +
           switch_to(static_cast<uint32_t>(r.fields[2]), " again");
  }
  if (r.type != CONTEGO_KMOD_REC_LOAD) return {};
  if (r.field_count < 1) return "; a module without image checksums: names assumed unchanged";
  return switch_to(static_cast<uint32_t>(r.fields[0]), "");
}

std::string KmodNames::switch_to(uint32_t crc, const char* again) {
  for (const Image& i : images_) {
    if (i.crc != crc) continue;
    current_ = &i.names;
    return fmt::format("; image CRC-32 {:08x}: {}, whose names the records now carry{}", crc,
                       i.source, again);
  }
  current_ = &none_;
  return fmt::format(
      "; image CRC-32 {:08x} is none of the reader's --policy files: records "
      "carry numbers only until one of them is loaded",
      crc);
}

bool write_kmod_record(monitor::AuditLog& log, const monitor::NameTable& names,
                       const contego_kmod_record& r, const std::string& load_note) {
  constexpr uint32_t kKept = CONTEGO_KMOD_REC_BYTES;
  // Every record carries the module's time of what it records (its
  // CLOCK_MONOTONIC when it took the record): the line's mono_us and t_us
  // are that instant, not the time the line is written (0: none, the
  // writer's time).
  const int64_t mono_us = r.time_us != 0 ? static_cast<int64_t>(r.time_us) : -1;
  const int64_t t_us = r.time_us != 0 ? static_cast<int64_t>(decision_wall_us(r.time_us)) : -1;
  const auto event = [&](const std::string& kind, const std::string& detail) {
    return log.event(kind, detail, t_us, mono_us);
  };
  switch (r.type) {
    case CONTEGO_KMOD_REC_DECISION: {
      core::AuditRecord a{};
      a.time_us = r.time_us;
      a.job = r.job;
      a.task = r.task;
      a.device = r.device;
      a.command = r.command;
      a.rule = r.rule;
      a.rule_kind = static_cast<core::RuleKind>(r.rule_kind);
      a.decision = static_cast<core::Decision>(r.decision);
      a.reason = static_cast<core::Reason>(r.reason);
      a.index = r.index;
      a.field_count = std::min<uint8_t>(r.field_count, core::kMaxFieldsPerCommand);
      std::copy_n(r.fields, a.field_count, a.fields);
      a.bus = r.bus;
      a.addr = r.addr;
      a.original = r.original;
      a.original_len = static_cast<uint16_t>(std::min<uint32_t>(r.original_len, kKept));
      if (r.substitute_len != 0) {
        a.substitute = r.substitute;
        a.substitute_len = static_cast<uint16_t>(std::min<uint32_t>(r.substitute_len, kKept));
      }
      monitor::RecordNames named = names.of(a);
      named.pid = r.pid;
      named.uid = r.uid;
      named.mono_us = mono_us;
      named.t_us = t_us;
      named.complain = (r.flags & CONTEGO_KMOD_REC_COMPLAIN) != 0;
      return log.decision(a, named);
    }
    case CONTEGO_KMOD_REC_SAFE_STATE: {
      const char* device =
          r.device < names.devices.size() ? names.devices[r.device].c_str() : "(unknown)";
      if ((r.why & ~CONTEGO_KMOD_SAFE_FAILED) == CONTEGO_KMOD_SAFE_EXIT) {
        if (r.device == CONTEGO_NONE) {
          return event("safe-state", fmt::format("contego.ko: {}; none of its actuators "
                                                 "has a safe state",
                                                 session_end(names, r)));
        }
        return event(
            "safe-state",
            fmt::format("contego.ko: {}; device {} ({}) at bus {} 0x{:02x} driven to its safe "
                        "state [{}]{}",
                        session_end(names, r), r.device, device, r.bus, r.addr,
                        hex(r.substitute, std::min<uint32_t>(r.substitute_len, kKept)),
                        (r.why & CONTEGO_KMOD_SAFE_FAILED) ? "; the write FAILED" : ""));
      }
      return event(
          "safe-state",
          fmt::format("contego.ko: device {} ({}) at bus {} 0x{:02x}: {} [{}]; {}{}", r.device,
                      device, r.bus, r.addr, safe_why(r.why),
                      hex(r.substitute, std::min<uint32_t>(r.substitute_len, kKept)), caller(r),
                      (r.why & CONTEGO_KMOD_SAFE_FAILED) ? "; the write FAILED" : ""));
    }
    case CONTEGO_KMOD_REC_LOAD:
      return event(
          "policy-load",
          fmt::format("contego.ko: image of {} bytes verified and in force{}; {}{}", r.count,
                      r.field_count >= 2
                          ? fmt::format(" in place (state carried over from image CRC-32 "
                                        "{:08x}, no safe state driven)",
                                        static_cast<uint32_t>(r.fields[1]))
                          : "",
                      caller(r), load_note));
    case CONTEGO_KMOD_REC_LOAD_REFUSED:
      if (r.reason == CONTEGO_KMOD_REFUSED_UNSAFE) {
        return event("policy-load-refused",
                     fmt::format("contego.ko: the image of {} bytes withdrawn after its load "
                                 "(a device absent, or no form on its adapter): {}; {}",
                                 r.count, load_note, caller(r)));
      }
      return event("policy-load-refused",
                   fmt::format("contego.ko: the verifier refused an image of {} bytes "
                               "(status {}); the policy in force stays; {}",
                               r.count, r.reason, caller(r)));
    case CONTEGO_KMOD_REC_SESSION_REFUSED: {
      // As the monitor's hello-refused for a task with its sessions live.
      const char* task = task_name(names, r);
      return event("session-refused",
                   fmt::format("contego.ko: task {} ({}): pid {} uid {} refused (EACCES): "
                               "the task already has {} live session(s), as many as the "
                               "policy allows",
                               r.task, task, r.pid, r.uid, r.count));
    }
    case CONTEGO_KMOD_REC_SESSIONS_FULL: {
      // No room for one more session in the module (EAGAIN): the task had
      // room under its own `sessions`, the module as a whole had none.
      const char* task = task_name(names, r);
      const int32_t open = r.fields[0], cap = r.fields[1];
      const std::string why =
          open >= cap
              ? fmt::format("the module has {} sessions open, its max_sessions", open)
              : fmt::format("no memory for one more session ({} open, max_sessions {})", open, cap);
      return event("session-refused",
                   fmt::format("contego.ko: task {} ({}): pid {} uid {} refused (EAGAIN): {}; "
                               "{} call(s) of the task so refused since the last report",
                               r.task, task, r.pid, r.uid, why, r.count));
    }
    case CONTEGO_KMOD_REC_HOLD: {
      // As the monitor's over-budget event.
      const char* task = task_name(names, r);
      return event("over-budget",
                   fmt::format("contego.ko: task {} ({}): over its budget of {} transfers "
                               "per job (job {}); {} transfer(s) held to the next release "
                               "since the last report; pid {} uid {}",
                               r.task, task, r.fields[0], r.job, r.count, r.pid, r.uid));
    }
    case CONTEGO_KMOD_REC_ADAPTER:
      return event(
          "adapter",
          r.why == CONTEGO_KMOD_ADAPTER_REMOVED
              ? fmt::format("contego.ko: adapter i2c-{} (the policy's bus {}) removed: its "
                            "node is gone, nothing is written to its devices until it "
                            "comes back",
                            r.count, r.bus)
              : fmt::format("contego.ko: adapter i2c-{} (the policy's bus {}) back: its "
                            "node again, its devices to their safe state",
                            r.count, r.bus));
    case CONTEGO_KMOD_REC_RESET:
      // As the monitor's reset event.
      return event("reset",
                   fmt::format("contego.ko: device {} ({}) at bus {} 0x{:02x} reset by "
                               "uid {} (pid {}); it was {}",
                               r.device,
                               r.device < names.devices.size() ? names.devices[r.device].c_str()
                                                               : "(unknown)",
                               r.bus, r.addr, r.uid, r.pid, r.index ? "latched" : "not latched"));
    case CONTEGO_KMOD_REC_INEXPRESSIBLE: {
      // As the monitor's inexpressible event, worded by the same function
      // from the planner's refusal the module recorded.
      contego_i2c_plan plan{};
      plan.form = CONTEGO_I2C_FORM_REFUSED;
      plan.refusal = r.reason;
      plan.flags = static_cast<uint16_t>(r.fields[3]);
      const auto lacks = static_cast<uint32_t>(r.fields[4]);
      plan.candidates_read = static_cast<uint8_t>(lacks & 0xff);
      plan.candidate_count = static_cast<uint8_t>(std::min<uint32_t>((lacks >> 8) & 0xff, 3));
      plan.candidates[0] = static_cast<uint8_t>(lacks >> 16);
      plan.candidates[1] = static_cast<uint8_t>(lacks >> 24);
      plan.candidates[2] = static_cast<uint8_t>(r.fields[5]);
      bus::Msg part[2];
      const size_t n = r.index == 2 ? 2 : 1;
      for (size_t k = 0; k < n; ++k) {
        const auto f = static_cast<uint32_t>(r.fields[k]);
        part[k] = {r.addr, static_cast<uint16_t>(f & 0xffff), static_cast<uint16_t>(f >> 16),
                   nullptr};
      }
      const std::string why =
          bus::refusal_reason({part, n}, static_cast<uint32_t>(r.fields[2]), plan);
      return event("inexpressible",
                   fmt::format("contego.ko: task {} ({}): bus {}: {}; the call refused "
                               "(EOPNOTSUPP) before any part of it acted; pid {} uid {}",
                               r.task, task_name(names, r), r.bus, why, r.pid, r.uid));
    }
    case CONTEGO_KMOD_REC_GAP:
      return event("audit-gap",
                   fmt::format("contego.ko: {} record(s) could not be taken (no reader or "
                               "the ring full); every call among them failed closed",
                               r.count));
    default:
      return event("fault", fmt::format("contego.ko: record {} of unknown type {}", r.seq,
                                        static_cast<int>(r.type)));
  }
}

int kmod_audit(const KmodAuditOptions& o) {
  // Signals are taken by the signalfd below: blocked before any thread (the
  // log's grower) starts, so none of them can die of SIGTERM mid-record.
  StopSignals signals;
  std::vector<KmodNames::Image> images;
  std::vector<monitor::SetupOptions> inputs;
  for (const std::string& policy : o.policies) inputs.emplace_back().policy = policy;
  for (const std::string& bundle : o.bundles) inputs.emplace_back().bundle = bundle;
  for (const monitor::SetupOptions& setup : inputs) {
    auto loaded = monitor::load_policy(setup);
    if (!loaded.ok()) {
      fmt::print(stderr, "contego kmod audit: {}\n", loaded.error());
      return 2;
    }
    KmodNames::Image i;
    i.source = loaded->source;
    std::memcpy(&i.crc, loaded->image.data() + 12, sizeof(i.crc));  // the header's CRC-32
    i.names = monitor::name_table(loaded->model);
    images.push_back(std::move(i));
  }
  std::string sources;
  for (const auto& i : images) sources += (sources.empty() ? "" : ", ") + i.source;
  KmodNames names(std::move(images));
  monitor::AuditLog log;
  if (Status s = log.open(o.audit, o.audit_options); !s.ok()) {
    fmt::print(stderr, "contego kmod audit: {}\n", s.error());
    return 2;
  }
  base::UniqueFd ring(::open(o.device.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC));
  if (!ring.valid()) {
    const int err = errno;
    fmt::print(stderr, "contego kmod audit: {}: {}{}\n", o.device, std::strerror(err),
               err == EBUSY    ? " (another reader holds the ring)"
               : err == ENOENT ? " (is contego.ko loaded?)"
                               : "");
    return 2;
  }
  // The metrics: a file that cannot be written refuses the start, naming it
  // (as the monitor's); later failures are said and the reader goes on.
  base::UniqueFd control;
  auto write_metrics = [&]() -> Status {
    auto state = kmod_status(control.get());
    if (!state.ok()) return make_error(fmt::format("the module's state: {}", state.error()));
    return monitor::write_metrics_file(o.metrics_file, kmod_metrics_text(*state));
  };
  const uint64_t interval_us = uint64_t{std::max(o.metrics_interval_s, 1u)} * 1000000;
  uint64_t next_metrics_us = monotonic_us() + interval_us;
  if (!o.metrics_file.empty()) {
    control = base::UniqueFd(::open(o.control.c_str(), O_RDONLY | O_CLOEXEC));
    Status s = control.valid() ? write_metrics()
                               : make_error(fmt::format("{}: {}", o.control, std::strerror(errno)));
    if (!s.ok()) {
      fmt::print(stderr, "contego kmod audit: --metrics-file: {}\n", s.error());
      return 2;
    }
  }
  log.event("start",
            fmt::format("contego kmod audit: reading {} for {} (names follow the policy-load "
                        "records)",
                        o.device, sources));
  if (!o.quiet) fmt::print(stderr, "contego kmod audit: {} -> {}\n", o.device, o.audit);

  // The size of the module's largest read (CT_READ_BATCH); acknowledged once
  // per batch, after every line of it is in the log.
  static contego_kmod_record batch[128];
  uint64_t taken = 0;
  bool stop = false;
  while (true) {
    const ssize_t n = ::read(ring.get(), batch, sizeof(batch));
    if (n < 0 && errno != EAGAIN && errno != EINTR) {
      fmt::print(stderr, "contego kmod audit: read {}: {}\n", o.device, std::strerror(errno));
      return 1;
    }
    if (n > 0) {
      const size_t count = static_cast<size_t>(n) / sizeof(batch[0]);
      size_t written = 0;
      while (written < count) {
        const std::string note = names.follow(batch[written]);
        if (!write_kmod_record(log, names.current(), batch[written], note)) break;
        ++written;
      }
      // What is in the log is acknowledged; the rest stays in the module.
      if (written > 0) {
        uint64_t seq = batch[written - 1].seq;
        if (::ioctl(ring.get(), CONTEGO_KMOD_AUDIT_ACK, &seq) != 0) {
          fmt::print(stderr, "contego kmod audit: acknowledge {}: {}\n", seq, std::strerror(errno));
          return 1;
        }
        taken += written;
      }
      if (written < count) {
        fmt::print(stderr,
                   "contego kmod audit: record {} could not be written to {}; stopping (the "
                   "module keeps it and fails calls closed until a reader takes it)\n",
                   batch[written].seq, o.audit);
        return 1;
      }
      continue;  // drain before waiting
    }
    if (stop) break;
    pollfd fds[2] = {{ring.get(), POLLIN, 0}, {signals.fd.get(), POLLIN, 0}};
    int timeout_ms = -1;
    if (control.valid()) {
      const uint64_t now = monotonic_us();
      timeout_ms = now >= next_metrics_us ? 0 : static_cast<int>((next_metrics_us - now) / 1000);
    }
    if (::poll(fds, 2, timeout_ms) < 0 && errno != EINTR) {
      fmt::print(stderr, "contego kmod audit: poll: {}\n", std::strerror(errno));
      return 1;
    }
    if (control.valid() && monotonic_us() >= next_metrics_us) {
      if (Status s = write_metrics(); !s.ok()) {
        fmt::print(stderr, "contego kmod audit: --metrics-file: {}\n", s.error());
      }
      next_metrics_us = monotonic_us() + interval_us;
    }
    signalfd_siginfo si{};
    while (::read(signals.fd.get(), &si, sizeof(si)) == static_cast<ssize_t>(sizeof(si))) {
      if (si.ssi_signo == SIGHUP) {
        auto what = log.reopen();
        log.event("signal", "SIGHUP: " + (what.ok() ? *what : what.error()));
      } else {
        stop = true;  // one more drain of what the ring holds, then out
      }
    }
  }
  if (control.valid()) {
    if (Status s = write_metrics(); !s.ok()) {
      fmt::print(stderr, "contego kmod audit: --metrics-file: {}\n", s.error());
    }
  }
  log.event("stop", fmt::format("contego kmod audit: {} record(s) taken", taken));
  if (!o.quiet) fmt::print(stderr, "contego kmod audit: stopped, {} record(s) taken\n", taken);
  return 0;
}

}  // namespace contego::cli
