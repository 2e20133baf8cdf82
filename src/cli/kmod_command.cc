// `contego kmod load --policy FILE [--bind TASK=USER]...`: hands the compiled
// image and the task bindings to contego.ko (docs/kernel-client.md) through
// its control device. The module verifies the image with the core's own
// verifier before it replaces the policy in force; a refused image leaves the
// old one. Bindings: each task's `user`, `group`, `exe`, `unit` and `cgroup`
// in the policy (a process that meets all of them acts as the task; the
// module checks them on every call from kernel facts), then each --bind
// TASK=USER (every process of that user); a process no binding names is no
// task and gets the policy's default (deny). With the image go what the
// monitor enforces beside it: each task's `sessions` (live sessions it may
// have) and actuations per job, and --budget-factor (the over-budget hold,
// as the monitor's; default 4, 0 = off).
// `contego kmod reload` takes the same options and loads in place: the
// running image is read back from the module, paired with the new one by
// name (cli/carry_pairs.h, as `contego reload` does in the monitor), and the
// module carries the state of the paired records over without driving any
// safe state; refused, the policy in force kept, when the devices differ.
// `contego kmod stats` prints the module's counters; `contego kmod audit`
// writes the module's audit ring to the audit log (kmod_audit.cc).
#include <fcntl.h>
#include <pwd.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fmt/core.h>
#include <fmt/format.h>
#include <linux/contego_kmod.h>
#include <map>
#include <nlohmann/json.hpp>
#include <sys/ioctl.h>
#include <sys/sysmacros.h>

#include "base/read_file.h"
#include "base/unique_fd.h"
#include "cli/audit_args.h"
#include "cli/bus_args.h"
#include "cli/carry_pairs.h"
#include "cli/command.h"
#include "cli/kmod_audit.h"
#include "cli/kmod_load_error.h"
#include "cli/kmod_status.h"
#include "cli/policy_load.h"
#include "cli/trusted_setup.h"
#include "image/image_model.h"
#include "monitor/monitor.h"
#include "monitor/peer_identity.h"
#include "monitor/sha256.h"

namespace contego::cli {
namespace {

// CONTEGO_KMOD_LOAD_VERSION 4's layout (the module's BUILD_BUG_ON says the same).
static_assert(sizeof(contego_kmod_load) == 360);

Result<uint32_t> uid_of(const std::string& user) {
  char* end = nullptr;
  const unsigned long n = std::strtoul(user.c_str(), &end, 10);
  if (!user.empty() && *end == '\0') return static_cast<uint32_t>(n);
  const passwd* pw = getpwnam(user.c_str());
  if (pw == nullptr) return make_error("no user '" + user + "'");
  return static_cast<uint32_t>(pw->pw_uid);
}

// One row of the module's binding table (kernel/contego_kmod.h).
Result<contego_kmod_bind> kmod_binding(uint16_t task, const monitor::TaskBinding& b) {
  contego_kmod_bind row{};
  row.task = task;
  row.uid = b.uid ? static_cast<uint32_t>(*b.uid) : CONTEGO_KMOD_ANY;
  row.gid = b.gid ? static_cast<uint32_t>(*b.gid) : CONTEGO_KMOD_ANY;
  if (b.has_exe) {
    row.flags |= CONTEGO_KMOD_BIND_EXE;
    row.exe_major = major(b.exe_dev);
    row.exe_minor = minor(b.exe_dev);
    row.exe_ino = b.exe_ino;
  }
  if (b.cgroup.size() >= sizeof(row.cgroup) || b.unit.size() >= sizeof(row.unit)) {
    return make_error(fmt::format("cgroup or unit name too long for the module ({} / {} bytes)",
                                  sizeof(row.cgroup) - 1, sizeof(row.unit) - 1));
  }
  std::copy(b.cgroup.begin(), b.cgroup.end(), row.cgroup);
  std::copy(b.unit.begin(), b.unit.end(), row.unit);
  return row;
}

// Each task's actuations per job (from the image's task records), its
// `sessions` (the policy's, 1 where it says nothing, as the monitor admits)
// and its `ignore_errno`.
bool fill_task_limits(contego_kmod_load* req, const image::ImageModel& model,
                      const std::vector<bundle::BundleTask>& bindings) {
  if (model.tasks.size() > CONTEGO_KMOD_MAX_TASKS) {
    fmt::print(stderr, "contego kmod: the image has {} tasks, the module takes {}\n",
               model.tasks.size(), CONTEGO_KMOD_MAX_TASKS);
    return false;
  }
  req->ntasks = static_cast<uint32_t>(model.tasks.size());
  for (size_t i = 0; i < model.tasks.size(); ++i) {
    req->actuations[i] = model.tasks[i].record.actuations_per_job;
    req->sessions[i] = 1;
    for (const auto& t : bindings) {
      if (t.name != model.tasks[i].name) continue;
      req->sessions[i] = t.sessions;
      req->ignore_errno[i] = t.ignore_errno;
    }
  }
  return true;
}

// --complain / --complain-for TASK as the module's bit per task; false (said
// on stderr) for a name that is no task of the image.
bool fill_complain(contego_kmod_load* req, const image::ImageModel& model, bool all,
                   const std::vector<std::string>& names) {
  std::vector<std::string> named;
  for (size_t i = 0; i < model.tasks.size() && i < 32; ++i) {
    const bool listed = std::find(names.begin(), names.end(), model.tasks[i].name) != names.end();
    if (!all && !listed) continue;
    req->complain |= 1u << i;
    named.push_back(model.tasks[i].name);
  }
  for (const std::string& n : names) {
    if (std::find(named.begin(), named.end(), n) == named.end()) {
      fmt::print(stderr,
                 "contego kmod load: --complain-for {}: the policy has no task of that name (the "
                 "module takes complain mode per task)\n",
                 n);
      return false;
    }
  }
  if (!named.empty()) {
    fmt::print(stderr,
               "contego kmod: WARNING: COMPLAIN MODE for task(s) {}: the policy's verdicts are "
               "only recorded; their commands act as sent. Do not run a robot unattended like "
               "this.\n",
               fmt::join(named, ", "));
  }
  return true;
}

// The module's control node, or a line on standard error saying which
// command could not open it and why (the caller exits 2).
base::UniqueFd open_control(const std::string& device, int flags, const char* command) {
  base::UniqueFd fd(::open(device.c_str(), flags | O_CLOEXEC));
  if (!fd.valid()) {
    fmt::print(stderr, "{}: {}: {} (is contego.ko loaded?)\n", command, device,
               std::strerror(errno));
  }
  return fd;
}

// CONTEGO_KMOD_RELOAD with `req` and the pairs of `now` with the image in
// force; returns the exit code (said on stderr when not 0).
int load_in_place(int fd, contego_kmod_load* req, const image::ImageModel& now, size_t nbinds) {
  auto running = running_image(fd);
  if (!running.ok()) {
    fmt::print(stderr, "contego kmod reload: {}\n", running.error());
    return 1;
  }
  auto old = image::deserialize(running->first);
  if (!old.ok()) {
    fmt::print(stderr, "contego kmod reload: the module's image cannot be read: {}\n", old.error());
    return 1;
  }
  auto pairing = pair_for_carry(now, *old);
  if (!pairing.ok()) {
    fmt::print(stderr, "contego kmod reload: refused, the policy in force stays: {}\n",
               pairing.error());
    return 1;
  }
  const Pairing& p = *pairing;
  std::vector<uint16_t> pairs;
  contego_kmod_reload r{};
  r.load = *req;
  r.running_crc = running->second;
  int k = 0;
  for (const auto* ids : {&p.tasks, &p.devices, &p.commands, &p.rates, &p.invariants}) {
    r.counts[k++] = static_cast<uint32_t>(ids->size());
    pairs.insert(pairs.end(), ids->begin(), ids->end());
  }
  r.pairs = reinterpret_cast<uintptr_t>(pairs.data());
  if (::ioctl(fd, CONTEGO_KMOD_RELOAD, &r) != 0) {
    const int err = errno;
    *req = r.load;
    if (err == ESTALE) {
      fmt::print(stderr,
                 "contego kmod reload: another policy was loaded while this one was paired with "
                 "it; the policy in force stays (run it again)\n");
    } else if (err == EIO && r.load.unsafe != 0) {
      fmt::print(stderr,
                 "contego kmod reload: refused: the safe state of {} has no form on its adapter "
                 "(a load in place drives none, so it checks them); the policy in force stays\n",
                 devices_named(now, r.load.unsafe));
    } else if (err == EINVAL && r.load.status == 0) {
      fmt::print(stderr,
                 "contego kmod reload: the module refused the pairs (the kernel log says why); "
                 "the policy in force stays\n");
    } else {
      fmt::print(stderr, "{}\n", kmod_load_error(err, r.load));
    }
    return 1;
  }
  const auto kept_tasks = static_cast<size_t>(std::count(p.kept.begin(), p.kept.end(), true));
  fmt::print(
      "contego kmod: loaded in place {} bytes, {} binding(s), state carried over ({} task(s), {} "
      "device(s), {} command(s), rate limit(s) and invariant(s)), started afresh: {}; no safe "
      "state driven, {} staged write(s) dropped, budget factor {}\n",
      r.load.size, nbinds, kept_tasks, p.devices.size(), p.paired,
      p.afresh.empty() ? "nothing" : fmt::format("{}", fmt::join(p.afresh, ", ")), r.staged_dropped,
      r.load.budget_factor);
  return 0;
}

// `contego kmod load` and `reload`'s options.
struct LoadArgs {
  std::string device = "/dev/contego", policy, raw_image, bundle, signature;
  std::string keys_dir = "/etc/contego/keys";
  bool require_signed = false;
  std::vector<std::string> binds;
  uint32_t budget_factor = monitor::Monitor::kDefaultBudgetFactor;
  bool budget_factor_given = false;
  bool complain = false;
  std::vector<std::string> complain_for;
  bool allow_degraded = false;
};

int load(const LoadArgs& a, const monitor::SetupOptions& source, bool in_place) {
  const std::string& device = a.device;
  const std::string& raw_image = a.raw_image;
  const std::vector<std::string>& binds = a.binds;
  const uint32_t budget_factor = a.budget_factor;
  const bool budget_factor_given = a.budget_factor_given;
  image::ImageModel model;  // the new image's (names: what a load in place pairs)
  std::vector<uint8_t> image;
  std::vector<contego_kmod_bind> table;
  contego_kmod_load req{};
  req.version = CONTEGO_KMOD_LOAD_VERSION;
  req.budget_factor = budget_factor;
  req.flags = a.allow_degraded ? CONTEGO_KMOD_LOAD_DEGRADED : 0;
  if (!raw_image.empty()) {
    // The bytes as they are: the module's verifier is the judge (tests).
    auto bytes = read_input_file(raw_image);
    if (!bytes.ok()) {
      fmt::print(stderr, "contego kmod: {}\n", bytes.error());
      return 2;
    }
    image.assign(bytes->begin(), bytes->end());
    // The tasks' limits as far as the bytes can be read (else none: the
    // module's verifier refuses such an image anyway).
    if (auto m = image::deserialize(image); m.ok()) {
      if (!fill_task_limits(&req, *m, {})) return 2;
      model = std::move(*m);
    } else if (in_place) {
      fmt::print(stderr, "contego kmod reload: the image cannot be paired: {}\n", m.error());
      return 2;
    }
  } else {
    auto loaded = monitor::load_policy(source);
    if (!loaded.ok()) {
      fmt::print(stderr, "contego kmod: {}\n", loaded.error());
      return 2;
    }
    image = loaded->image;
    model = loaded->model;
    if (loaded->budget_factor) {  // a bundle's, which the command line may only repeat
      if (budget_factor_given && budget_factor != *loaded->budget_factor) {
        fmt::print(stderr,
                   "contego kmod: --budget-factor {}: the bundle says {}; a bundle's host side is "
                   "not overridden\n",
                   budget_factor, *loaded->budget_factor);
        return 2;
      }
      req.budget_factor = *loaded->budget_factor;
    }
    if (!loaded->buses.empty()) {
      fmt::print(stderr,
                 "contego kmod: note: the bundle's bus adapters are the monitor's; contego.ko "
                 "takes its buses from its own parameters (adapters=, buses=)\n");
    }
    if (!fill_task_limits(&req, loaded->model, loaded->bindings)) return 2;
    if (!fill_complain(&req, loaded->model, a.complain, a.complain_for)) return 2;
    std::map<std::string, uint16_t> ids;
    for (size_t i = 0; i < loaded->model.tasks.size(); ++i) {
      ids[loaded->model.tasks[i].name] = static_cast<uint16_t>(i);
    }
    auto task_id = [&](const std::string& task) -> Result<uint16_t> {
      auto it = ids.find(task);
      if (it == ids.end()) return make_error("the policy has no task '" + task + "'");
      return it->second;
    };
    // The policy's own words first (user, group, exe, unit, cgroup: every
    // fact named must hold), as the monitor checks them on each hello.
    for (const auto& t : loaded->bindings) {
      auto b =
          monitor::resolve_binding(t.name, {t.exe, t.user, t.group, t.unit, t.cgroup, t.sessions});
      if (!b.ok()) {
        fmt::print(stderr, "contego kmod: {}\n", b.error());
        return 2;
      }
      if (!b->unresolved.empty()) {
        fmt::print(stderr, "contego kmod: task {}: {}\n", t.name, b->unresolved);
        return 2;
      }
      if (!b->binds()) continue;
      auto row = kmod_binding(*task_id(t.name), *b);
      if (!row.ok()) {
        fmt::print(stderr, "contego kmod: task {}: {}\n", t.name, row.error());
        return 2;
      }
      table.push_back(*row);
    }
    // Then --bind TASK=USER: every process of that user.
    for (const std::string& b : binds) {
      const auto eq = b.find('=');
      if (eq == std::string::npos) {
        fmt::print(stderr, "contego kmod: --bind {}: expected TASK=USER\n", b);
        return 2;
      }
      auto id = task_id(b.substr(0, eq));
      auto uid = uid_of(b.substr(eq + 1));
      if (!id.ok() || !uid.ok()) {
        fmt::print(stderr, "contego kmod: --bind {}: {}\n", b, !id.ok() ? id.error() : uid.error());
        return 2;
      }
      for (const auto& row : table) {
        if (row.uid == *uid && row.gid == CONTEGO_KMOD_ANY && row.flags == 0 &&
            row.cgroup[0] == '\0' && row.unit[0] == '\0') {
          fmt::print(stderr, "contego kmod: --bind {}: uid {} bound twice\n", b, *uid);
          return 2;
        }
      }
      monitor::TaskBinding only_uid;
      only_uid.uid = *uid;
      table.push_back(*kmod_binding(*id, only_uid));
    }
  }
  if (table.size() > CONTEGO_KMOD_MAX_BINDS) {
    fmt::print(stderr, "contego kmod: more than {} bindings\n", CONTEGO_KMOD_MAX_BINDS);
    return 2;
  }
  const base::UniqueFd fd = open_control(device, O_RDWR, "contego kmod");
  if (!fd.valid()) return 2;
  req.image = reinterpret_cast<uintptr_t>(image.data());
  req.size = static_cast<uint32_t>(image.size());
  req.nbinds = static_cast<uint32_t>(table.size());
  req.binds = reinterpret_cast<uintptr_t>(table.data());
  if (in_place) return load_in_place(fd.get(), &req, model, table.size());
  const int rc = ::ioctl(fd.get(), CONTEGO_KMOD_LOAD, &req);
  const int err = errno;
  // What the module could not do at the load, as the monitor words it at start.
  std::string problems;
  if (req.unreadable != 0) {
    problems = fmt::format("the first sample of {} could not be read",
                           devices_named(model, req.unreadable));
  }
  if (req.unsafe != 0) {
    problems += fmt::format("{}the safe state of {} could not be driven",
                            problems.empty() ? "" : "; ", devices_named(model, req.unsafe));
  }
  if (rc != 0 && err == EIO && !problems.empty()) {
    fmt::print(stderr,
               "contego kmod: load refused: {} (the device absent, or its adapter has no form for "
               "the transfer; the kernel log and `contego kmod audit` say which); the policy in "
               "force stays (--allow-degraded loads anyway)\n",
               problems);
    return 1;
  }
  if (rc != 0) {
    fmt::print(stderr, "{}\n", kmod_load_error(err, req));
    return 1;
  }
  if (!problems.empty()) {
    fmt::print(stderr, "contego kmod: --allow-degraded: loaded although {}\n", problems);
  }
  fmt::print(
      "contego kmod: loaded {} bytes, {} binding(s), {} device(s) in their safe state, budget "
      "factor {}{}\n",
      image.size(), table.size(), req.devices, req.budget_factor,
      req.complain != 0 ? fmt::format(", complain mode for task mask 0x{:x}", req.complain) : "");
  return 0;
}

// `contego kmod status`: what the module enforces, through its control
// node: the image in force (read back: its SHA-256 is the one `contego
// check --emit` and a bundle name), its tasks and devices, and the counters.
int status(const std::string& device, bool json) {
  const base::UniqueFd fd = open_control(device, O_RDONLY, "contego kmod status");
  if (!fd.valid()) return 2;
  auto state = kmod_status(fd.get());
  if (!state.ok()) {
    fmt::print(stderr, "contego kmod status: {}\n", state.error());
    return 2;
  }
  const nlohmann::ordered_json& j = *state;
  const auto& c = j["counters"];
  auto n = [&](const char* key) { return c[key].get<uint64_t>(); };
  if (json) {
    fmt::print("{}\n", j.dump());
    return 0;
  }
  if (!j["loaded"].get<bool>()) {
    fmt::print(
        "contego.ko: no policy in force (every call is refused until `contego kmod load`)\n");
  } else if (j.contains("image_sha256")) {
    fmt::print("policy:   image SHA-256 {} (CRC-32 {}, {} bytes)\n",
               j["image_sha256"].get<std::string>(), j["image_crc32"].get<std::string>(),
               j["image_bytes"].get<size_t>());
    if (j.contains("tasks")) {
      std::vector<std::string> tasks = j["tasks"], devices;
      for (const auto& d : j["devices"]) {
        devices.push_back(fmt::format("{} (bus {} {})", d["name"].get<std::string>(),
                                      d["bus"].get<int>(), d["addr"].get<std::string>()));
      }
      fmt::print("tasks:    {}\ndevices:  {}\n", fmt::join(tasks, ", "), fmt::join(devices, ", "));
    }
  } else {
    fmt::print("policy:   in force ({})\n", j.value("image_error", ""));
  }
  if (const std::string degraded = j["degraded"]; !degraded.empty()) {
    fmt::print("DEGRADED: {} (loaded with --allow-degraded)\n", degraded);
  }
  if (const std::string latched = j["latched"]; !latched.empty()) {
    fmt::print("LATCHED:  {} (held in the safe state; `contego kmod reset DEVICE` clears it)\n",
               latched);
  }
  fmt::print("audit:    {}\n", j["audit_reader"].get<bool>()
                                   ? "a reader is attached"
                                   : "NO READER: every call fails closed until `contego kmod "
                                     "audit` runs");
  fmt::print("sessions: {} open, {} ended, {} refused for room, {} over their task's `sessions`\n",
             n("sessions"), n("session_ends"), n("sessions_refused"), n("sessions_limited"));
  fmt::print(
      "checks:   {} ({} performed, {} refused, {} ignored, {} fail-safe; {} holds; {} refused "
      "without a form on their adapter)\n",
      n("checks"), n("performed"), n("refused"), n("ignored"), n("failsafe"), n("holds"),
      n("inexpressible"));
  fmt::print(
      "loads:    {} ({} refused: by the verifier, or a sensor or safe state failing at load)\n",
      n("loads"), n("refused_loads"));
  return 0;
}

int stats(const std::string& device) {
  const base::UniqueFd fd = open_control(device, O_RDONLY, "contego kmod stats");
  if (!fd.valid()) return 2;
  contego_kmod_stats s{};
  const int rc = ::ioctl(fd.get(), CONTEGO_KMOD_STATS, &s);
  if (rc != 0) {
    fmt::print(stderr, "contego kmod: stats: {}\n", std::strerror(errno));
    return 2;
  }
  fmt::print(
      "loaded={} loads={} refused_loads={} checks={} performed={} refused={} ignored={} "
      "failsafe={} reader={} records={} unrecorded={} audit_refused={} sessions={} "
      "session_ends={} sessions_refused={} sessions_limited={} holds={} samples={} "
      "sample_errors={} inexpressible={} undriven=0x{:x} unread=0x{:x} latched=0x{:x}\n",
      s.loaded, s.loads, s.refused_loads, s.checks, s.performed, s.refused, s.ignored, s.failsafe,
      s.reader, s.records, s.unrecorded, s.audit_refused, s.sessions, s.session_ends,
      s.sessions_refused, s.sessions_limited, s.holds, s.samples, s.sample_errors, s.inexpressible,
      s.undriven, s.unread, s.latched);
  return 0;
}

// `contego kmod reset DEVICE`: the monitor's `contego reset` for contego.ko.
// The device is named from the image in force, whose CRC the request
// carries: a load in between is refused (ESTALE), not reset by number.
// Exit 0 when the latch is clear, 1 when the module refused, 2 when it
// cannot be reached or has no such device.
int reset(const std::string& device, const std::string& name) {
  const base::UniqueFd fd = open_control(device, O_RDWR, "contego kmod reset");
  if (!fd.valid()) return 2;
  auto running = running_image(fd.get());
  if (!running.ok()) {
    fmt::print(stderr, "contego kmod reset: {}\n", running.error());
    return 1;
  }
  auto model = image::deserialize(running->first);
  if (!model.ok()) {
    fmt::print(stderr, "contego kmod reset: the image in force cannot be read: {}\n",
               model.error());
    return 1;
  }
  contego_kmod_reset req{};
  while (req.device < model->devices.size() && model->devices[req.device].name != name) {
    ++req.device;
  }
  if (req.device == model->devices.size()) {
    fmt::print(stderr, "contego kmod reset: the policy in force has no device '{}'\n", name);
    return 2;
  }
  req.crc = running->second;
  if (::ioctl(fd.get(), CONTEGO_KMOD_RESET, &req) != 0) {
    const int err = errno;
    fmt::print(stderr, "contego kmod reset: {}: {}\n", name,
               err == ESTALE ? std::string("another policy was loaded meanwhile (run it again)")
               : err == EIO  ? std::string("its record could not be taken (is `contego kmod "
                                            "audit` running?); nothing was reset")
                             : std::string(std::strerror(err)));
    return 1;
  }
  fmt::print("contego kmod reset: {} {}\n", name,
             req.was_latched ? "was latched; its latch is cleared" : "was not latched");
  return 0;
}

}  // namespace

void register_kmod(CLI::App& app) {
  auto* cmd = app.add_subcommand("kmod", "Drive contego.ko, the in-kernel checked i2c-dev");
  cmd->require_subcommand(1);
  // `load` and `reload` take the same options; reload keeps the state.
  auto add_load = [cmd](const char* name, const char* what, bool in_place) {
    auto args = std::make_shared<LoadArgs>();
    auto* ld = cmd->add_subcommand(name, what);
    ld->add_option("--policy", args->policy, "policy file");
    ld->add_option(
        "--bundle", args->bundle,
        "a policy bundle (`contego check --emit-bundle`): the image and the task bindings");
    ld->add_flag("--require-signed", args->require_signed,
                 "load only a --bundle whose minisign signature verifies with a key of --keys-dir");
    ld->add_option("--signature", args->signature,
                   "the bundle's minisign signature (default: BUNDLE.minisig; one that exists is "
                   "always checked)");
    ld->add_option("--keys-dir", args->keys_dir, "trusted minisign public keys (*.pub)")
        ->capture_default_str();
    ld->add_option("--unverified-image", args->raw_image,
                   "send this file's bytes as the image unchecked here (the module verifies)");
    ld->add_option("--bind", args->binds, "TASK=USER: processes of USER (name or uid) act as TASK");
    ld->add_option("--device", args->device, "the module's control device")->capture_default_str();
    add_budget_option(ld, &args->budget_factor)->each([args](const std::string&) {
      args->budget_factor_given = true;
    });
    add_complain_options(ld, &args->complain, &args->complain_for);
    if (!in_place) {
      ld->add_flag("--allow-degraded", args->allow_degraded,
                   "load even when an actuator's safe state cannot be driven (refused otherwise, "
                   "the policy in force kept)");
    }
    ld->callback([args, name, in_place] {
      const int sources = !args->policy.empty() + !args->bundle.empty() + !args->raw_image.empty();
      if (sources != 1) {
        fmt::print(stderr,
                   "contego kmod {}: give one of --policy, --bundle or --unverified-image\n", name);
        return set_exit_code(2);
      }
      if (args->require_signed && args->bundle.empty()) {
        fmt::print(stderr,
                   "contego kmod {}: --require-signed loads a signed --bundle FILE only "
                   "(`contego check --emit-bundle`, then `minisign -Sm FILE`)\n",
                   name);
        return set_exit_code(2);
      }
      monitor::SetupOptions source;
      source.policy = args->policy;
      source.bundle = args->bundle;
      source.require_signed = args->require_signed;
      source.signature = args->signature;
      source.keys_dir = args->keys_dir;
      set_exit_code(load(*args, source, in_place));
    });
  };
  add_load("load",
           "Load a policy into contego.ko (verified there; every device driven to its safe state)",
           false);
  add_load("reload",
           "Load a policy into contego.ko in place: the state of the records it keeps (by name) "
           "carries over, no safe state is driven; the devices must stay the same",
           true);
  auto device = std::make_shared<std::string>("/dev/contego");
  auto* st = cmd->add_subcommand("stats", "Print contego.ko's counters");
  st->add_option("--device", *device, "the module's control device")->capture_default_str();
  st->callback([device] { set_exit_code(stats(*device)); });
  auto reset_device = std::make_shared<std::string>();
  auto* rs = cmd->add_subcommand(
      "reset", "Clear a latched device in contego.ko (root; audited, as `contego reset`)");
  rs->add_option("DEVICE", *reset_device, "the device's name in the policy in force")->required();
  rs->add_option("--device", *device, "the module's control device")->capture_default_str();
  rs->callback([device, reset_device] { set_exit_code(reset(*device, *reset_device)); });
  auto status_json = std::make_shared<bool>(false);
  auto* ss = cmd->add_subcommand(
      "status",
      "Show what contego.ko enforces: the image in force (its SHA-256), its tasks and devices, "
      "the audit reader, sessions and counters (root)");
  ss->add_option("--device", *device, "the module's control device")->capture_default_str();
  ss->add_flag("--json", *status_json, "as JSON");
  ss->callback([device, status_json] { set_exit_code(status(*device, *status_json)); });
  auto audit = std::make_shared<KmodAuditOptions>();
  auto* au = cmd->add_subcommand(
      "audit",
      "Write contego.ko's audit ring to the audit log (the module fails calls closed "
      "while no reader runs)");
  au->add_option("--policy", audit->policies,
                 "the policy loaded into the module (names); once per policy the module may run: "
                 "each record is named from the image in force");
  au->add_option("--bundle", audit->bundles,
                 "the same for a policy bundle the module may run (`contego kmod load --bundle`)");
  au->add_option("--audit", audit->audit, "audit log file (- = standard error)");
  au->add_option("--device", audit->device, "the module's audit device")->capture_default_str();
  au->add_flag("--quiet", audit->quiet, "no start and stop lines on standard error");
  au->add_option("--metrics-file", audit->metrics_file,
                 "write the module's state as Prometheus metrics to this file (node_exporter's "
                 "textfile collector), at start, every --metrics-interval and at the stop");
  au->add_option("--metrics-interval", audit->metrics_interval_s, "seconds between two writes")
      ->capture_default_str()
      ->check(CLI::Range(1u, 3600u));
  au->add_option("--control", audit->control,
                 "the module's control device (its state, for --metrics-file)")
      ->capture_default_str();
  add_audit_options(au, &audit->audit_options);
  au->callback([audit] {
    if ((audit->policies.empty() && audit->bundles.empty()) || audit->audit.empty()) {
      fmt::print(stderr,
                 "contego kmod audit: give --policy FILE (or --bundle FILE) and --audit LOG\n");
      return set_exit_code(2);
    }
    set_exit_code(kmod_audit(*audit));
  });
}

}  // namespace contego::cli
