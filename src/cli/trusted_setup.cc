#include "cli/trusted_setup.h"

#include <string.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <fmt/core.h>
#include <fmt/format.h>
#include <optional>
#include <set>
#include <sys/stat.h>

#include "base/read_file.h"
#include "bundle/minisign.h"
#include "bus/linux_i2cdev.h"
#include "gate/transfer.h"
#include "monitor/sha256.h"

namespace contego::monitor {
namespace {

std::string errno_text(int err) {
  const char* name = strerrorname_np(err);
  return fmt::format("{} ({})", name != nullptr ? name : std::to_string(err), strerror(err));
}

std::string where(const std::string& name, const core::DeviceRecord& r,
                  const char* noun = "device") {
  return fmt::format("{} {} at i2c-{} 0x{:02x}", noun, name, r.bus, r.addr);
}

struct Probe {
  int err;          // 0: the device answered
  const char* how;  // what was sent
};
// i2cdetect's probe: a quick write, except where that can corrupt an
// EEPROM's write pointer or lock some chips (0x30-0x37, 0x50-0x5f), for a
// ten-bit address and on an adapter without quick: a one-byte read. Neither
// carries data a device could take as a command.
Probe probe(bus::Bus& b, const core::DeviceRecord& r) {
  const bool read_range = (r.addr >= 0x30 && r.addr <= 0x37) || (r.addr >= 0x50 && r.addr <= 0x5f);
  if (r.ten_bit == 0 && !read_range && (b.funcs() & bus::kFuncSmbusQuick) != 0) {
    return {b.quick(r.addr, false), "an SMBus quick write"};
  }
  uint8_t byte = 0;
  bus::Msg m{r.addr, static_cast<uint16_t>(gate::kMsgRead | (r.ten_bit ? gate::kMsgTen : 0)), 1,
             &byte};
  return {b.transfer({&m, 1}), "a one-byte read"};
}

// One register read: the pointer byte, then one byte (a combined transfer).
int read_register(bus::Bus& b, const core::DeviceRecord& r, uint8_t reg, uint8_t* value) {
  const uint16_t ten = r.ten_bit ? gate::kMsgTen : 0;
  bus::Msg m[2] = {{r.addr, ten, 1, &reg},
                   {r.addr, static_cast<uint16_t>(gate::kMsgRead | ten), 1, value}};
  return b.transfer({m, 2});
}

}  // namespace

// A device configured before contego started (or by a run before it) need
// not hold its power-on values: the shadow the core keeps of a register map
// is read back from the device where every register answers a read. A
// device that refuses one keeps the power-on shadow (write-only devices).
std::vector<std::string> seed_shadows(core::Checker& checker, const image::ImageModel& model,
                                      const std::map<int, bus::Bus*>& adapters) {
  std::vector<std::string> notes;
  for (uint16_t d = 0; d < checker.device_count(); ++d) {
    const core::DeviceRecord& r = checker.device(d);
    if (r.profile != core::Profile::kRegisterMap) continue;
    auto it = adapters.find(r.bus);
    if (it == adapters.end()) continue;
    const std::string name = d < model.devices.size() ? model.devices[d].name : std::to_string(d);
    std::vector<std::pair<uint8_t, uint8_t>> values;
    int err = 0;
    uint8_t regs[core::kMaxRegisters];
    const uint32_t nregs = checker.command_registers(d, regs);
    for (uint32_t i = 0; i < nregs; ++i) {
      const uint8_t reg = regs[i];
      uint8_t v = 0;
      if ((err = read_register(*it->second, r, reg, &v)) != 0) {
        notes.push_back(fmt::format(
            "{}: register 0x{:02x} cannot be read ({}); the shadow keeps the power-on values",
            where(name, r), reg, errno_text(err)));
        break;
      }
      values.emplace_back(reg, v);
    }
    if (err != 0 || values.empty()) continue;
    for (auto [reg, v] : values) checker.seed_register(d, reg, v);
    notes.push_back(fmt::format("{}: shadow read back from the device ({} registers)",
                                where(name, r), values.size()));
  }
  return notes;
}

namespace {

Result<std::string> read_descriptor(int fd) {
  std::string text;
  char buf[65536];
  for (;;) {
    const ssize_t n = ::pread(fd, buf, sizeof(buf), static_cast<off_t>(text.size()));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return make_error(fmt::format("descriptor {}: {}", fd, errno_text(errno)));
    if (n == 0) return text;
    if (text.size() + static_cast<size_t>(n) > bundle::kMaxBundleBytes) {
      return make_error(
          fmt::format("descriptor {}: more than {} bytes", fd, bundle::kMaxBundleBytes));
    }
    text.append(buf, static_cast<size_t>(n));
  }
}

// The signer of a bundle file: "" if it has no signature and none is
// required. The signature covers the bytes read once (`text`), which are
// the bytes decoded: nothing can change between the check and the use.
Result<std::string> check_signature(const SetupOptions& o, std::string_view text) {
  const std::string path = o.signature.empty() ? o.bundle + ".minisig" : o.signature;
  struct stat st {};
  const bool present = ::stat(path.c_str(), &st) == 0;
  if (!present && o.signature.empty() && !o.require_signed) return std::string();
  if (!present) {
    return make_error(fmt::format(
        "{}bundle {} has no signature {} (sign it with `minisign -Sm {}`, the public key in {})",
        o.require_signed ? "--require-signed: " : "", o.bundle, path, o.bundle, o.keys_dir));
  }
  auto signature = read_input_file(path);
  if (!signature.ok()) return make_error("signature " + signature.error());
  auto keys = bundle::load_trusted_keys(o.keys_dir);
  if (!keys.ok()) {
    return make_error(
        fmt::format("bundle {} is signed ({}), but {}", o.bundle, path, keys.error()));
  }
  auto v = bundle::verify_minisign(text, *signature, path, *keys);
  if (!v.ok()) return make_error(v.error() + ": refusing bundle " + o.bundle);
  return fmt::format("signed by key ID {} ({}), trusted comment \"{}\"", v->key_id_hex,
                     v->key_source, v->trusted_comment);
}

Result<LoadedPolicy> load_bundle(const SetupOptions& o) {
  const bool from_fd = o.bundle_fd >= 0;
  if (from_fd && o.require_signed) {
    return make_error(
        "--require-signed: a policy compiled by `contego monitor --policy` is not signed; give "
        "--bundle FILE with its minisign signature");
  }
  auto text = from_fd ? read_descriptor(o.bundle_fd) : read_input_file(o.bundle);
  if (!text.ok()) return make_error("bundle " + text.error());
  std::string signer;
  if (!from_fd) {
    auto checked = check_signature(o, *text);
    if (!checked.ok()) return make_error(checked.error());
    signer = *checked;
  }
  const std::string name =
      from_fd ? (o.policy.empty() ? fmt::format("bundle on descriptor {}", o.bundle_fd) : o.policy)
              : o.bundle;
  auto b = bundle::decode_bundle(*text, name);
  if (!b.ok()) return make_error(b.error());
  const std::string hash = bundle::image_sha256(b->image);
  if (!o.image_sha256.empty() && hash != o.image_sha256) {
    return make_error(
        fmt::format("{}: its image has SHA-256 {}; --image-sha256 expects {}: "
                    "refusing it",
                    name, hash, o.image_sha256));
  }
  if (!o.image.empty()) {
    auto bytes = read_input_file(o.image);
    if (!bytes.ok()) return make_error("image " + bytes.error());
    if (std::string_view(reinterpret_cast<const char*>(b->image.data()), b->image.size()) !=
        *bytes) {
      return make_error(
          fmt::format("image {} (SHA-256 {}) is not the image {} {} (SHA-256 {}): refusing it",
                      o.image, sha256_hex(*bytes), from_fd ? "policy" : "bundle", name,
                      from_fd ? "compiles to" : "carries", hash));
    }
  }
  LoadedPolicy p;
  // From `contego monitor --policy`: named as before, the policy and its image.
  p.source = from_fd ? fmt::format("{} (SHA-256 {})", o.image.empty() ? name : o.image, hash)
                     : fmt::format("{} (bundle of {}, SHA-256 {}{}{})", name, b->policy, hash,
                                   signer.empty() ? "" : ", ", signer);
  auto model = image::deserialize(b->image);
  if (!model.ok()) return make_error(fmt::format("{}: {}", name, model.error()));
  p.model = std::move(*model);
  p.image = std::move(b->image);
  p.bindings = std::move(b->tasks);
  p.budget_factor = b->budget_factor;
  p.buses = std::move(b->buses);
  return p;
}

// The bundle's host side with the command line's: the command line may
// repeat what the bundle says and add buses it does not name, never
// contradict it (what decides is the signed bundle).
Status apply_bundle_host_side(const SetupOptions& o, const LoadedPolicy& out, uint32_t* factor,
                              std::map<int, std::string>* buses) {
  *factor = o.budget_factor;
  *buses = o.real_buses;
  if (out.budget_factor) {
    if (o.budget_factor_given && o.budget_factor != *out.budget_factor) {
      return make_error(fmt::format(
          "--budget-factor {}: the bundle {} says {}; a bundle's host side is not overridden "
          "(drop the option, or emit the bundle with `contego check --emit-bundle "
          "--budget-factor N`)",
          o.budget_factor, out.source, *out.budget_factor));
    }
    *factor = *out.budget_factor;
  }
  for (const auto& [n, path] : out.buses) {
    const auto given = o.real_buses.find(n);
    const bool virtual_bus =
        std::find(o.virtual_buses.begin(), o.virtual_buses.end(), n) != o.virtual_buses.end();
    if ((given != o.real_buses.end() && given->second != path) || virtual_bus) {
      return make_error(fmt::format(
          "--{}bus {}: the bundle {} says bus {} is {}; a bundle's host side is not overridden",
          virtual_bus ? "virtual-" : "", virtual_bus ? std::to_string(n) : given->second,
          out.source, n, path));
    }
    (*buses)[n] = path;
  }
  if (buses->empty() && o.virtual_buses.empty() && o.buses.empty()) {
    return make_error(
        "no bus: give at least one --bus N=/dev/i2c-N or --virtual-bus N (or a bundle that "
        "names its buses: `contego check --emit-bundle --bus N=PATH`)");
  }
  return {};
}

}  // namespace

Result<LoadedPolicy> load_verified(const SetupOptions& o) {
  if (!o.bundle.empty() || o.bundle_fd >= 0) return load_bundle(o);
  if (o.require_signed) {
    return make_error(
        "--require-signed: an image alone carries no signature (nor the task bindings); give "
        "--bundle FILE (`contego check --emit-bundle`) and its minisign signature");
  }
  if (o.image.empty()) {
    return make_error(
        "no policy: give a bundle (`contego check --emit-bundle`) or an image pinned by its "
        "SHA-256");
  }
  // A verified image (`contego check --emit`): it is used only when its
  // SHA-256 is the one given (the tool compares it with its policy instead).
  auto bytes = read_input_file(o.image);
  if (!bytes.ok()) return make_error("image " + bytes.error());
  const std::string hash = sha256_hex(*bytes);
  if (o.image_sha256.empty()) {
    return make_error(fmt::format(
        "image {} (SHA-256 {}) is not pinned: give --image-sha256 or the --policy it was "
        "emitted from",
        o.image, hash));
  }
  if (hash != o.image_sha256) {
    return make_error(fmt::format("image {} has SHA-256 {}; --image-sha256 expects {}: refusing it",
                                  o.image, hash, o.image_sha256));
  }
  LoadedPolicy p;
  p.image.assign(bytes->begin(), bytes->end());
  auto model = image::deserialize(p.image);
  if (!model.ok()) return make_error(fmt::format("image {}: {}", o.image, model.error()));
  p.model = std::move(*model);
  p.source = fmt::format("{} (SHA-256 {})", o.image, hash);
  return p;
}

Result<std::pair<Monitor::ComplainScope, std::string>> complain_scope(
    const SetupOptions& o, const image::ImageModel& model) {
  Monitor::ComplainScope scope;
  scope.all = o.complain;
  scope.tasks.assign(model.tasks.size(), false);
  std::vector<std::string> named;
  for (const std::string& name : o.complain_for) {
    bool found = false;
    for (size_t i = 0; i < model.tasks.size(); ++i) {
      if (model.tasks[i].name != name) continue;
      scope.tasks[i] = found = true;
      named.push_back("task " + name);
    }
    for (size_t d = 0; d < model.devices.size() && d < 32; ++d) {
      if (model.devices[d].name != name) continue;
      scope.devices |= 1u << d;
      found = true;
      named.push_back("device " + name);
    }
    if (!found) {
      return make_error(
          fmt::format("--complain-for {}: the policy has no task or device of "
                      "that name",
                      name));
    }
  }
  std::string words = "mode enforce";
  if (scope.all) {
    words = "mode complain (every task and device: commands act as sent, verdicts recorded)";
  } else if (!named.empty()) {
    words = fmt::format(
        "mode complain for {} (their commands act as sent, verdicts recorded); "
        "enforce for the rest",
        fmt::join(named, ", "));
  }
  return std::make_pair(std::move(scope), std::move(words));
}

Result<HostTasks> host_tasks(const std::vector<bundle::BundleTask>& tasks,
                             const std::map<std::string, uint16_t>& ids) {
  HostTasks h;
  for (const auto& task : tasks) {
    auto b = resolve_binding(
        task.name, {task.exe, task.user, task.group, task.unit, task.cgroup, task.sessions});
    if (!b.ok()) return make_error(b.error());
    if (!b->unresolved.empty())
      h.warnings.push_back(b->unresolved + ": every hello for it is refused");
    h.bindings[task.name] = *b;
    const auto id = ids.find(task.name);
    if (id == ids.end() || id->second >= core::kMaxTasks) continue;
    if (task.phase_us) h.facts.phases[id->second] = *task.phase_us;
    h.facts.ignore_errnos[id->second] = task.ignore_errno;
  }
  return h;
}

Result<std::unique_ptr<Trusted>> setup(const SetupOptions& o, const LoadedPolicy& out) {
  auto t = std::make_unique<Trusted>();
  if (Status s = t->audit.open(o.audit, o.audit_options); !s.ok()) return make_error(s.error());
  t->source = out.source;
  t->model = out.model;
  t->image_sha256 = sha256_hex(
      std::string_view(reinterpret_cast<const char*>(out.image.data()), out.image.size()));
  t->decider = std::make_unique<CoreDecider>();
  const core::LoadResult lr =
      t->decider->checker().load(out.image.data(), static_cast<uint32_t>(out.image.size()));
  if (lr.status != core::LoadStatus::kOk) {
    return make_error(
        fmt::format("policy image of {} refused by the verifier: {} (section {}, record {})",
                    out.source, core::load_status_name(lr.status), lr.section, lr.index));
  }
  for (size_t i = 0; i < out.model.tasks.size(); ++i) {
    t->tasks[out.model.tasks[i].name] = static_cast<uint16_t>(i);
  }
  if (out.bindings.empty() && !out.model.tasks.empty()) {
    t->warnings.push_back(
        "the image names no task bindings (user, group, exe, unit, cgroup): give its bundle or "
        "--policy to enforce them; any peer --client-uid allows can claim any task");
  }
  auto host = host_tasks(out.bindings, t->tasks);
  if (!host.ok()) return make_error(fmt::format("policy {}: {}", out.source, host.error()));
  t->warnings.insert(t->warnings.end(), host->warnings.begin(), host->warnings.end());
  t->bindings = host->bindings;
  if (!o.task.empty() && !t->tasks.contains(o.task)) {
    return make_error(fmt::format("policy {} declares no task '{}'", out.source, o.task));
  }
  t->monitor = std::make_unique<Monitor>(*t->decider, t->audit);
  t->monitor->set_names(name_table(out.model));
  std::vector<uint32_t> actuates;
  for (const auto& a : out.model.access) actuates.push_back(a.actuate_devices);
  t->monitor->set_task_devices(std::move(actuates));
  if (Status s = apply_bundle_host_side(o, out, &t->budget_factor, &t->real_buses); !s.ok()) {
    return make_error(s.error());
  }
  t->monitor->set_budget_factor(t->budget_factor);
  t->monitor->set_task_facts(std::move(host->facts));
  std::map<int, bus::Bus*> adapters;  // bus number -> adapter
  std::map<int, std::string> adapter_name;
  for (const auto& [n, path] : t->real_buses) {
    auto b = bus::LinuxI2cDev::open(path);
    if (!b.ok()) return make_error(fmt::format("bus {}: {}", n, b.error()));
    adapters[n] = b->get();
    adapter_name[n] = path;
    t->buses.push_back(std::move(*b));
  }
  for (int n : o.virtual_buses) {
    auto vb = std::make_unique<bus::VirtualBus>();
    Trusted::VirtualDevices models{n, vb.get(), std::make_shared<bus::Pca9685>(0x40),
                                   std::make_shared<bus::GoPiGo2>(0x08)};
    vb->attach(models.pca9685);
    vb->attach(models.gopigo);
    vb->attach(std::make_shared<bus::LineFollower>(0x06));
    t->virtual_devices.push_back(models);
    adapters[n] = vb.get();
    adapter_name[n] = "a virtual bus";
    t->buses.push_back(std::move(vb));
  }
  for (const auto& [n, b] : o.buses) {
    adapters[n] = b;
    adapter_name[n] = "a test bus";
  }
  for (const auto& [n, b] : adapters) t->monitor->add_bus(static_cast<uint8_t>(n), b);
  auto complain = complain_scope(o, out.model);
  if (!complain.ok()) return make_error(fmt::format("policy {}: {}", out.source, complain.error()));
  t->monitor->set_complain(complain->first);
  t->audit.event("start", fmt::format("policy {}, {} tasks, worst-case cost {} instructions, {}",
                                      out.source, out.model.tasks.size(),
                                      t->decider->checker().worst_case_cost(), complain->second));
  if (complain->first.any()) {
    // Loud on purpose: complain mode must never be left on by accident.
    fmt::print(stderr,
               "contego: WARNING: COMPLAIN MODE ({}): the policy's verdicts are only recorded; "
               "the commands act as the programs send them. Do not run a robot unattended "
               "like this.\n",
               complain->second);
  }

  const auto& devices = out.model.devices;
  auto device_name = [&](uint16_t d) {
    return d < devices.size() ? devices[d].name : std::to_string(d);
  };
  auto device_record = [&](uint16_t d) -> const core::DeviceRecord& {
    return t->decider->device(d);
  };
  // Phase 1: the policy's buses against the adapters (no bus traffic).
  std::vector<std::string> problems;
  std::set<int> used;
  for (uint16_t d = 0; d < t->decider->device_count(); ++d) {
    const core::DeviceRecord& r = device_record(d);
    used.insert(r.bus);
    if (adapters.count(r.bus) == 0) {
      problems.push_back(
          fmt::format("{}: no adapter for bus {} (give --bus {}=/dev/i2c-{} or "
                      "--virtual-bus {})",
                      where(device_name(d), r), r.bus, r.bus, r.bus, r.bus));
    }
  }
  for (const auto& [n, name] : adapter_name) {
    if (used.count(n) != 0) continue;
    t->warnings.push_back(fmt::format(
        "bus {} ({}): no device of the policy is on it; nothing will be sent to it", n, name));
    t->audit.event("unused-bus", t->warnings.back());
  }
  // Phase 2: every device answers its probe; nothing else is sent before.
  for (uint16_t d = 0; d < t->decider->device_count(); ++d) {
    const core::DeviceRecord& r = device_record(d);
    auto it = adapters.find(r.bus);
    if (it == adapters.end()) continue;
    if (const auto [err, how] = probe(*it->second, r); err != 0) {
      problems.push_back(fmt::format("{} does not answer: {} on {} failed with {}",
                                     where(device_name(d), r), how, adapter_name[r.bus],
                                     errno_text(err)));
    }
  }
  auto refuse = [&](const std::string& stage) -> Result<std::unique_ptr<Trusted>> {
    std::string msg = fmt::format("refusing to start ({}):", stage);
    for (const auto& p : problems) msg += "\n  " + p;
    msg += "\n  (--allow-degraded starts anyway)";
    t->audit.event("start-refused", msg);
    return make_error(msg);
  };
  if (!problems.empty() && !o.allow_degraded) return refuse("devices missing");
  // Phase 2b: the shadow of every register map, from the device itself.
  for (const std::string& note : seed_shadows(t->decider->checker(), out.model, adapters)) {
    t->audit.event("shadow", note);
  }
  // Phase 3: the first sample of every sensor.
  for (const DeviceFailure& f : t->monitor->sample_all()) {
    problems.push_back(fmt::format("{} cannot be read: {}",
                                   where(device_name(f.device), device_record(f.device), "sensor"),
                                   errno_text(f.err)));
  }
  if (!problems.empty() && !o.allow_degraded) return refuse("sensors unreadable");
  // Phase 4: the safe state of every actuator.
  for (const DeviceFailure& f : t->monitor->drive_safe_state(o.safe_state_reason)) {
    problems.push_back(fmt::format("safe state of {} cannot be applied: {}",
                                   where(device_name(f.device), device_record(f.device)),
                                   errno_text(f.err)));
  }
  if (!problems.empty() && !o.allow_degraded) return refuse("safe state not applied");
  if (!problems.empty()) {
    std::string msg = "--allow-degraded: starting although";
    for (const auto& p : problems) msg += "\n  " + p;
    t->audit.event("degraded-start", msg);
    t->degraded = problems;
  }
  t->monitor->start_sampling();
  return t;
}

std::string virtual_state(const Trusted& trusted) {
  std::string out;
  for (const auto& v : trusted.virtual_devices) {
    v.adapter->with_lock([&] {
      out += fmt::format("bus {} gopigo2 0x08 motion=0x{:02x} left={} right={} frames={}\n", v.bus,
                         v.gopigo->motion(), v.gopigo->left_speed(), v.gopigo->right_speed(),
                         v.gopigo->frames());
      out += fmt::format("bus {} pca9685 0x40", v.bus);
      for (int c = 0; c < 16; ++c) {
        out += fmt::format(" led{}={}/{}", c, v.pca9685->led_on(c), v.pca9685->led_off(c));
      }
      out += "\n";
    });
  }
  return out;
}

}  // namespace contego::monitor
