// What `contego run` and `contego monitor` share: compile the policy, load it
// into the core, open the buses (real /dev/i2c-N or a virtual bus with the
// built-in device models) and build the monitor.
//
// Start fails closed: setup() refuses, with one line per problem naming the
// device, its bus and address, when
//  - a device of the policy is on a bus that no adapter serves;
//  - a device does not answer its probe (an SMBus quick write, or a one-byte
//    read at 0x30-0x37, 0x50-0x5f, for ten-bit addresses and on adapters
//    without quick: i2cdetect's choice); then nothing but the probes reached
//    any adapter;
//  - a sensor's first sample cannot be read (then no safe state was sent);
//  - an actuator's safe state cannot be written.
// A refusal is audited (`start-refused`). `allow_degraded` starts anyway:
// the problems are audited (`degraded-start`) and returned in `degraded`.
// An adapter that no device of the policy uses is only a warning.
#ifndef CONTEGO_CLI_TRUSTED_SETUP_H_
#define CONTEGO_CLI_TRUSTED_SETUP_H_

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "base/result.h"
#include "bundle/bundle.h"
#include "bus/virtual_bus.h"
#include "image/image_model.h"
#include "monitor/audit_log.h"
#include "monitor/core_decider.h"
#include "monitor/monitor.h"
#include "monitor/peer_identity.h"

namespace contego::monitor {

struct SetupOptions {
  std::string policy;  // policy source file (compiled by the tool, never by the daemon)
  std::string image;   // a verified image (`contego check --emit`) instead of compiling
  std::string bundle;  // a policy bundle (`contego check --emit-bundle`)
  int bundle_fd = -1;  // a bundle on a descriptor: `contego monitor` compiled `policy`
  // minisign: a bundle file with a signature (`signature`, default
  // BUNDLE.minisig) must verify with a key of `keys_dir`; `require_signed`
  // refuses everything else (an unsigned bundle, an image, a compiled policy).
  bool require_signed = false;
  std::string signature;
  std::string keys_dir = "/etc/contego/keys";
  std::string image_sha256;    // the image's expected SHA-256 (hex); or `policy` must compile to it
  std::string audit = "-";     // audit log path ("-" = stderr)
  AuditOptions audit_options;  // --audit-unsafe, --audit-max-bytes, --audit-keep
  std::string task;            // contego run: the program's task, checked before any bus is touched
  std::map<int, std::string> real_buses;  // bus number -> /dev/i2c-N
  std::vector<int> virtual_buses;  // buses hosting PCA9685 0x40, GoPiGo2 0x08, line follower 0x06
  uint32_t budget_factor = Monitor::kDefaultBudgetFactor;  // set_budget_factor (0 = off)
  bool budget_factor_given = false;  // on the command line: it must agree with a bundle's
  bool allow_degraded = false;
  // Complain mode (Monitor::set_complain): every command, or those of the
  // tasks and devices named, acts as sent; the policy's verdict is recorded.
  bool complain = false;
  std::vector<std::string> complain_for;
  std::string safe_state_reason = "start";  // the audit detail of the safe state at start
  // Tests: adapters supplied by the caller (not owned; must outlive the result).
  std::map<int, bus::Bus*> buses;
};

struct Trusted {
  std::unique_ptr<CoreDecider> decider;
  AuditLog audit;
  std::vector<std::unique_ptr<bus::Bus>> buses;
  std::unique_ptr<Monitor> monitor;
  std::map<std::string, uint16_t> tasks;  // name -> id
  // Who may run each task (the policy's user/group/exe/unit/cgroup/sessions),
  // resolved on this host: an unknown user or group, or a missing exe, fails setup.
  std::map<std::string, TaskBinding> bindings;
  std::string source;       // the policy or image file, with the image's SHA-256
  image::ImageModel model;  // what the core enforces: for the names a reload pairs
  std::string image_sha256;
  // The host side in force (a bundle's, or the command line's): what a
  // reload's bundle must agree with.
  uint32_t budget_factor = Monitor::kDefaultBudgetFactor;
  std::map<int, std::string> real_buses;
  std::vector<std::string> warnings;  // e.g. an adapter no device uses
  std::vector<std::string> degraded;  // with allow_degraded: what was wrong at start
  // The models on the virtual buses, for virtual_state().
  struct VirtualDevices {
    int bus = 0;
    bus::VirtualBus* adapter = nullptr;
    std::shared_ptr<bus::Pca9685> pca9685;
    std::shared_ptr<bus::GoPiGo2> gopigo;
  };
  std::vector<VirtualDevices> virtual_devices;
};

// The actuator state of the virtual buses' models, one line per device
// (`bus 1 gopigo2 0x08 motion=0x78 left=.. right=.. frames=N`, `bus 1
// pca9685 0x40 led0=ON/OFF ...`): what the tests read back after a run.
std::string virtual_state(const Trusted& trusted);

// Fails with a message naming the file and the reason (diagnostics, verifier status).
struct LoadedPolicy {
  std::string source;  // what the start event and errors name
  std::vector<uint8_t> image;
  image::ImageModel model;
  // Who may run each task (user, exe, ...): from the policy source or a
  // bundle; an image alone does not carry them (then empty).
  std::vector<bundle::BundleTask> bindings;
  // A bundle's host side, if it names it (bundle::Bundle).
  std::optional<uint32_t> budget_factor;
  std::map<int, std::string> buses;
};
// What the trusted daemon loads, never compiling: a bundle (a file, or the
// descriptor `contego monitor` passes after compiling `policy`), or an image
// pinned by `image_sha256`. With a bundle, `image` and `image_sha256` must
// name the bundle's image. cli/policy_load.h adds compiling a policy.
Result<LoadedPolicy> load_verified(const SetupOptions& options);

// Reads every register the commands of each register-map device cover back
// from the device and seeds the checker's shadow with them (a device that
// refuses a read keeps its power-on shadow). One note per device.
std::vector<std::string> seed_shadows(core::Checker& checker, const image::ImageModel& model,
                                      const std::map<int, bus::Bus*>& adapters);

Result<std::unique_ptr<Trusted>> setup(const SetupOptions& options, const LoadedPolicy& policy);

// A bundle's task facts on this host, by the image's task ids: who may run
// each task (a binding this host cannot meet is a warning: every hello for
// the task is refused) and what the monitor keeps per task.
struct HostTasks {
  std::map<std::string, TaskBinding> bindings;
  std::vector<std::string> warnings;
  Monitor::TaskFacts facts;
};
Result<HostTasks> host_tasks(const std::vector<bundle::BundleTask>& tasks,
                             const std::map<std::string, uint16_t>& ids);

// The monitor's complain scope from --complain / --complain-for, and the
// mode's words for the start record and the banner. Fails for a name the
// policy does not have.
Result<std::pair<Monitor::ComplainScope, std::string>> complain_scope(
    const SetupOptions& options, const image::ImageModel& model);

}  // namespace contego::monitor

#endif  // CONTEGO_CLI_TRUSTED_SETUP_H_
