/* C ABI of the trusted core, for adapters written in C: an OP-TEE pseudo-TA,
 * a kernel hook, or any host that cannot use the C++ API. Freestanding: the
 * caller provides the checker's storage (contego_checker_size() bytes, aligned
 * to contego_checker_align()); nothing is allocated. Thread-safety: none (one
 * call at a time per checker). Every function is bounded and makes no OS call
 * except through the callbacks the host installs. Every function checks its
 * pointers: a NULL checker or transaction fails closed (contego_load: status 1
 * too-small; contego_check: reject not-loaded / malformed, errno 1 / 22;
 * contego_combine_transfer with NULL verdicts: refuse), a NULL output is left
 * alone, and the other calls do nothing or answer 0. */
#ifndef CONTEGO_CORE_C_H_
#define CONTEGO_CORE_C_H_

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct contego_checker contego_checker; /* opaque */

/* Mirrors contego::core::Verdict (same limits: 64 writes, 256 bytes). */
#define CONTEGO_MAX_EMITS 64
#define CONTEGO_MAX_EMIT_BYTES 256
#define CONTEGO_MAX_FIELDS 8
#define CONTEGO_NONE 0xFFFFu
/* The core's limits (contego/core/limits.h): task and device ids are below
 * these (a u32 mask each); a sensor sample is at most this long. */
#define CONTEGO_MAX_TASKS 32
#define CONTEGO_MAX_DEVICES 32
#define CONTEGO_MAX_SAMPLE_BYTES 64

enum contego_decision {
  CONTEGO_ALLOW = 0,
  CONTEGO_IGNORE = 1,
  CONTEGO_FAILSAFE = 2,
  CONTEGO_REJECT = 3
};
enum contego_tx_kind { CONTEGO_TX_WRITE = 1, CONTEGO_TX_READ = 2, CONTEGO_TX_QUICK = 3 };

typedef struct contego_transaction {
  uint16_t task; /* CONTEGO_NONE: not a declared task */
  uint8_t bus;
  uint8_t kind; /* enum contego_tx_kind */
  uint16_t addr;
  uint8_t ten_bit;
  uint8_t pad;
  uint32_t job; /* 0: unknown, windows of the task's period */
  uint32_t len;
  const uint8_t* bytes;
  uint64_t now_us;
} contego_transaction;

typedef struct contego_verdict {
  uint8_t decision; /* enum contego_decision */
  uint8_t reason;   /* contego::core::Reason */
  uint8_t rule_kind;
  uint8_t reply_errno;
  uint16_t rule;
  uint16_t device;
  uint16_t addr;
  uint8_t bus;
  uint8_t emit_count;
  uint16_t emit_bytes_used;
  uint16_t emit_len[CONTEGO_MAX_EMITS];
  uint8_t emit_bytes[CONTEGO_MAX_EMIT_BYTES];
} contego_verdict;

typedef struct contego_audit_record {
  uint64_t time_us;
  uint32_t job;
  uint16_t task;
  uint16_t device;
  uint16_t command;
  uint16_t rule;
  uint8_t rule_kind;
  uint8_t decision;
  uint8_t reason;
  uint8_t index;
  int32_t fields[CONTEGO_MAX_FIELDS];
  uint8_t field_count;
  uint8_t bus;
  uint16_t addr;
  uint16_t original_len;
  uint16_t substitute_len;
  const uint8_t* original;
  const uint8_t* substitute;
} contego_audit_record;

typedef struct contego_host {
  void* context;
  /* Latest sample of sensor `device` into buf; returns bytes (0 = none). May be NULL. */
  uint32_t (*read_sample)(void* context, uint16_t device, uint8_t* buf, uint32_t capacity,
                          uint64_t* taken_at_us);
  /* One record per decoded command; pointers valid during the call. May be NULL. */
  void (*audit)(void* context, const contego_audit_record* record);
} contego_host;

typedef struct contego_load_result {
  uint8_t status; /* contego::core::LoadStatus, 0 = ok */
  uint32_t section;
  uint32_t index;
} contego_load_result;

size_t contego_checker_size(void);
size_t contego_checker_align(void);
/* Constructs a checker in `mem` (no image loaded). NULL if too small or misaligned. */
contego_checker* contego_checker_init(void* mem, size_t size);
contego_load_result contego_load(contego_checker* c, const uint8_t* image, uint32_t size);
void contego_set_host(contego_checker* c, const contego_host* host);
void contego_check(contego_checker* c, const contego_transaction* tx, contego_verdict* out);
int contego_safe_state(contego_checker* c, uint16_t device, contego_verdict* out);
/* What contego_safe_state would write, the model left as it was. */
int contego_preview_safe_state(contego_checker* c, uint16_t device, contego_verdict* out);
/* Transfers: the checks between begin and commit/abort are one unit (docs/core.md,
 * "Transfers"). contego_combine_transfer returns the action (0 perform, 1 refuse,
 * 2 ignore, 3 substitute, 4 safe state) and stores the deciding verdict's index. */
void contego_begin_transfer(contego_checker* c);
void contego_commit_transfer(contego_checker* c);
void contego_abort_transfer(contego_checker* c, uint8_t decision);
uint8_t contego_combine_transfer(const contego_verdict* verdicts, uint32_t count,
                                 uint32_t* decider);
void contego_reset_latch(contego_checker* c, uint16_t device);
/* A session of `task` ended: its session-scoped state words restart and its
 * staged register writes are dropped; returns how many (Checker::end_session). */
uint32_t contego_end_session(contego_checker* c, uint16_t task);
/* A register-map device's shadow: the registers its commands cover
 * (ascending, into `regs` of 256 entries; returns how many, 0 for another
 * profile), and one register's value as read back from the device (0: bad
 * device or profile). A host seeds them after a load, before any check. */
uint32_t contego_command_registers(const contego_checker* c, uint16_t device, uint8_t* regs);
int contego_seed_register(contego_checker* c, uint16_t device, uint8_t reg, uint8_t value);
int contego_latched(const contego_checker* c, uint16_t device);
uint32_t contego_worst_case_cost(const contego_checker* c);
/* The period of `task` in microseconds (0: no such task). A host that keeps
 * the job grid (job k spans [phase + (k-1)*period, phase + k*period)) numbers
 * each transaction's job from it, as the user-space monitor does. */
uint32_t contego_task_period_us(const contego_checker* c, uint16_t task);
/* What a host needs of device `device` to sample it and to drive its safe
 * state (contego::core::DeviceRecord's fields of that name). 0: no such device. */
#define CONTEGO_ROLE_ACTUATOR 1
#define CONTEGO_ROLE_SENSOR 2
typedef struct contego_device_info {
  uint8_t role; /* CONTEGO_ROLE_* bits */
  uint8_t bus;
  uint8_t ten_bit;
  uint8_t sample_request_len; /* sensors: bytes written before a sample is read */
  uint16_t addr;
  uint8_t sample_len; /* sensors: bytes read per sample (0: not sampled) */
  uint8_t pad;
  uint8_t sample_request[8];
  uint32_t sample_period_us;  /* sensors: how often the host samples */
  uint32_t max_sample_age_us; /* sensors: older samples make signals unavailable */
} contego_device_info;
uint32_t contego_device_count(const contego_checker* c);
int contego_device_info_of(const contego_checker* c, uint16_t device, contego_device_info* out);
/* The access matrix's row of `task`: bit k, the task may actuate device k
 * (0: no such task). What a task's exit drives to the safe state. */
uint32_t contego_task_actuates(const contego_checker* c, uint16_t task);
/* Reload in place (Checker::carry_from): `c`, freshly loaded, takes over the
 * run-time state of `old` for the records `map` pairs. Each array has one
 * entry per record of c's image (contego_record_counts_of), the old image's
 * id of the same record or 0xFFFF. 1: taken (*staged_dropped: staged writes
 * of unpaired tasks dropped); 0: refused, nothing taken (a pair disagrees, an
 * id out of range, a checker not loaded or inside a transfer). */
typedef struct contego_record_counts {
  uint32_t tasks, devices, commands, rates, invariants;
} contego_record_counts;
typedef struct contego_carry_map {
  const uint16_t *tasks, *devices, *commands, *rates, *invariants;
} contego_carry_map;
void contego_record_counts_of(const contego_checker* c, contego_record_counts* out);
int contego_carry_from(contego_checker* c, const contego_checker* old, const contego_carry_map* map,
                       uint32_t* staged_dropped);
const char* contego_load_status_name(uint8_t status);
const char* contego_reason_name(uint8_t reason);
const char* contego_decision_name(uint8_t decision);

#ifdef __cplusplus
}
#endif

#endif /* CONTEGO_CORE_C_H_ */
