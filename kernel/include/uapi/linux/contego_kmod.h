/* SPDX-License-Identifier: GPL-2.0 WITH Linux-syscall-note */
/* The control interface of contego.ko (docs/kernel-client.md): the ioctls on
 * /dev/contego with which `contego kmod load` hands the module a compiled
 * policy image and the task bindings. Shared by the module (C, kernel) and
 * the CLI (C++, user space).
 */
#ifndef _UAPI_LINUX_CONTEGO_KMOD_H
#define _UAPI_LINUX_CONTEGO_KMOD_H

#include <linux/ioctl.h>
#include <linux/types.h>

#define CONTEGO_KMOD_MAX_IMAGE (4u << 20) /* bytes */
#define CONTEGO_KMOD_MAX_BINDS 64

/* Who acts as task `task` (its id in the image): a process that meets every
 * fact the binding names -- its effective uid, a group it is in (effective or
 * supplementary), the executable it runs (device and inode, as stat(2) gives
 * them), its cgroup (v2 path, that cgroup or one below it) and/or a systemd
 * unit (a component of that path). The first binding a process meets, in
 * table order, gives its task; a process no binding names is no task: the
 * policy's default (deny) applies to it.
 */
#define CONTEGO_KMOD_ANY 0xFFFFFFFFu /* uid, gid: not a condition */
#define CONTEGO_KMOD_BIND_EXE 1u     /* flags: exe_major/minor/ino must match */

struct contego_kmod_bind {
	__u32 uid;		/* CONTEGO_KMOD_ANY: any */
	__u32 gid;		/* CONTEGO_KMOD_ANY: any */
	__u16 task;
	__u16 flags;
	__u32 exe_major;	/* major(st_dev) of the executable */
	__u32 exe_minor;	/* minor(st_dev) */
	__u32 pad;
	__u64 exe_ino;
	char cgroup[128];	/* "": any; NUL-terminated absolute path */
	char unit[64];		/* "": any; a systemd unit name */
};

/* What the monitor enforces per task besides the image, handed over with
 * the image (docs/kernel-client.md "Sessions", "Budget"): how many live
 * sessions each task may have (the policy's `sessions`, default 1) and its
 * actuations per job (N, the image's), with the over-budget hold's factor.
 */
#define CONTEGO_KMOD_MAX_TASKS 32
#define CONTEGO_KMOD_MAX_TASK_SESSIONS 64 /* the policy's largest `sessions` */

/* The layout of struct contego_kmod_load. Its size is in the ioctl number
 * too: a module refuses a CONTEGO_KMOD_LOAD of another size or version with
 * EPROTO (and says so in the kernel log); an older module answers ENOTTY.
 */
#define CONTEGO_KMOD_LOAD_VERSION 4

/* contego_kmod_load.flags */
#define CONTEGO_KMOD_LOAD_DEGRADED 1 /* in force although a safe state was not driven */
/* CONTEGO_KMOD_REC_LOAD_REFUSED's reason: a safe state not driven, a sensor not read */
#define CONTEGO_KMOD_REFUSED_UNSAFE 0xff

struct contego_kmod_load {
	__u32 version; /* in: CONTEGO_KMOD_LOAD_VERSION; out on EPROTO: the module's */
	__u32 budget_factor; /* in: the over-budget hold: factor x actuations per job (0 = off) */
	__u64 image; /* in: user pointer to the image */
	__u32 size; /* in: its size in bytes */
	__u32 nbinds; /* in: entries at `binds` */
	__u64 binds; /* in: user pointer to struct contego_kmod_bind[nbinds] */
	__u32 status; /* out: the core verifier's LoadStatus (0 = loaded) */
	__u32 section; /* out: where the verifier stopped */
	__u32 index; /* out */
	__u32 devices; /* out: devices driven to their safe state at load */
	__u32 ntasks; /* in: the image's tasks: entries of sessions[] and actuations[] */
	/*
	 * in: bit i: task i in complain mode (docs/learn.md): its calls are
	 * checked and recorded (CONTEGO_KMOD_REC_COMPLAIN) and act as sent.
	 * A module that predates it reads 0 here: it enforces
	 */
	__u32 complain;
	__u32 sessions[CONTEGO_KMOD_MAX_TASKS]; /* in: live sessions task i may have, 1..64 */
	__u32 actuations[CONTEGO_KMOD_MAX_TASKS]; /* in: task i's actuations per job (N) */
	/*
	 * in: (version 3) the policy's `ignore_errno`:
	 * a call of task i the checks ignored fails with
	 * it; 0: it succeeds (the paper's IGNORE)
	 */
	__u8 ignore_errno[CONTEGO_KMOD_MAX_TASKS];
	__u32 flags; /* in: (version 4) CONTEGO_KMOD_LOAD_* */
	/*
	 * out: (version 4) bit d: device d's declared safe state could not be
	 * driven at load; `unreadable`: sensor d's first sample could not be
	 * read (then no safe state is driven). Unless
	 * CONTEGO_KMOD_LOAD_DEGRADED, such a load is refused (EIO) and the
	 * policy in force stays, as the monitor refuses to start
	 */
	__u32 unsafe;
	__u32 unreadable;
	__u32 pad; /* zero (EINVAL otherwise) */
};

/* A load in place (CONTEGO_KMOD_RELOAD): the new image takes over the
 * running one's run-time state for the records the caller pairs (by name,
 * from the running image it read back with CONTEGO_KMOD_IMAGE), and no safe
 * state is driven. Refused, the running policy kept, when another image was
 * loaded since (ESTALE: running_crc), when `counts` are not the new image's
 * (EINVAL), when the core finds a pair that disagrees (EINVAL), when a
 * device's new safe state has no form on its adapter (EIO, load.unsafe
 * says which), and for any load.flags (EINVAL).
 */
struct contego_kmod_reload {
	struct contego_kmod_load load; /* in/out: as CONTEGO_KMOD_LOAD */
	__u32 running_crc; /* in: header CRC-32 of the image the pairs were made against */
	/*
	 * in: the new image's tasks, devices, commands, rates and
	 * invariants: the entries of each run at `pairs`
	 */
	__u32 counts[5];
	/*
	 * in: user pointer to __u16[sum of counts]: per record of the
	 * new image, in that order, the running image's id of the same
	 * record or 0xFFFF (starts afresh)
	 */
	__u64 pairs;
	__u32 staged_dropped; /* out: staged register writes of unpaired tasks dropped */
	__u32 pad;
};

/* The image in force, read back (CONTEGO_KMOD_IMAGE). ENOENT: none loaded;
 * ENOSPC: `size` is too small (size then says how many bytes it needs).
 */
struct contego_kmod_image {
	__u64 buf;	/* in: user pointer */
	__u32 size;	/* in: bytes at buf; out: the image's size */
	__u32 crc;	/* out: its header CRC-32 (the LOAD record's fields[0]) */
};

struct contego_kmod_stats {
	__u64 loads; /* images accepted */
	__u64 refused_loads; /* images refused: the verifier, a sensor or safe state at load */
	__u64 checks; /* transactions checked */
	__u64 performed; /* calls that acted on a bus */
	__u64 refused; /* calls refused (errno to the program) */
	__u64 ignored; /* calls ignored (success, nothing acted) */
	__u64 failsafe; /* calls replaced by a substitute or the safe state */
	__u64 records; /* audit records taken by the ring */
	__u64 unrecorded; /* records lost (no reader, ring full): each failed its call closed */
	__u64 audit_refused; /* calls refused (EIO) because their record could not be taken */
	__u64 sessions; /* sessions open now (processes acting as a task, ends deferred) */
	__u64 session_ends; /* sessions ended: each drove its task's actuators to their safe state */
	__u64 sessions_refused; /* calls refused (EAGAIN): no room for one more session */
	__u64 samples; /* sensor samples read from a bus */
	__u64 sample_errors; /* sensor samples that failed (their signals unavailable) */
	__u32 loaded; /* 1: an image is in force */
	__u32 reader; /* 1: an audit reader holds /dev/contego-audit */
	/* Added with CONTEGO_KMOD_LOAD_VERSION 2 (a shorter STATS gets the fields before): */
	__u64 sessions_limited; /* calls refused (EACCES): their task had its `sessions` live */
	__u64 holds; /* transfers held to a later release (over-budget hold) */
	/* Added with CONTEGO_KMOD_LOAD_VERSION 4: */
	__u64 inexpressible; /* calls refused (EOPNOTSUPP): a part had no form on the adapter */
	/*
	 * The policy in force, loaded with CONTEGO_KMOD_LOAD_DEGRADED: bit d,
	 * device d's safe state not driven since the load (`undriven`),
	 * sensor d not read since (`unread`); a bit clears when that succeeds
	 */
	__u32 undriven;
	__u32 unread;
	__u32 latched; /* bit d: device d latched (CONTEGO_KMOD_RESET clears it) */
	__u32 pad; /* zero */
};

/* An operator's reset of a latched device (CONTEGO_KMOD_RESET), as the
 * monitor's `contego reset`: recorded (CONTEGO_KMOD_REC_RESET), then the
 * latch and the device's violation count cleared. ENOENT: no policy in
 * force; ESTALE: another image than `crc` is in force; EINVAL: no such
 * device, or `pad` not zero; EIO: the record could not be taken (no reader,
 * the ring full): nothing reset.
 */
struct contego_kmod_reset {
	__u32 device; /* in: the device's id in the image in force */
	__u32 crc; /* in: that image's header CRC-32 (CONTEGO_KMOD_IMAGE's) */
	__u32 was_latched; /* out: 1 if it was latched */
	__u32 pad;
};

/* The audit ring (/dev/contego-audit, docs/kernel-client.md "Audit"): one
 * record per decoded command the core decides (its audit host callback) and
 * one per module event, taken before anything of the call acts. A call whose
 * record the ring cannot take (no reader attached, the ring full) does not
 * act: it fails with EIO, the devices go to their safe state, and the next
 * record taken is an audit-gap record counting what was lost. read() returns
 * whole records, oldest first, without consuming them; CONTEGO_KMOD_AUDIT_ACK
 * frees every record up to a sequence number once the reader has stored it,
 * so a reader that dies loses nothing: the next one is handed the records
 * not yet acknowledged. One reader at a time (EBUSY), CAP_SYS_ADMIN.
 */
enum contego_kmod_record_type {
	CONTEGO_KMOD_REC_DECISION = 1, /* the core's audit record of one command */
	CONTEGO_KMOD_REC_SAFE_STATE = 2, /* device's safe state driven; `why` */
	/*
	 * an image verified and in force; count = its size,
	 * fields[0] = its header's CRC-32; field_count 2 for a
	 * load in place (CONTEGO_KMOD_RELOAD): fields[1] = the
	 * CRC-32 of the image it replaced (no safe state driven)
	 */
	CONTEGO_KMOD_REC_LOAD = 3,
	/*
	 * an image refused; reason = the verifier's status, or
	 * CONTEGO_KMOD_REFUSED_UNSAFE after its load record:
	 * fields[0] = the devices whose safe state could not be
	 * driven, fields[1] = the sensors that could not be read
	 * (bit d: device d), fields[2] (field_count 3) = the
	 * CRC-32 of the image in force again
	 */
	CONTEGO_KMOD_REC_LOAD_REFUSED = 4,
	CONTEGO_KMOD_REC_GAP = 5, /* count = records lost before this one */
	/*
	 * a process of `task` (pid, uid) would have opened a
	 * session beyond the task's `sessions` (count): its
	 * call was refused with EACCES
	 */
	CONTEGO_KMOD_REC_SESSION_REFUSED = 6,
	/*
	 * over-budget hold of `task`: count = transfers held
	 * since the last such record (at most one a second per
	 * task), job = the job whose budget ran out, fields[0] =
	 * the budget; pid/uid: the process held this time
	 */
	CONTEGO_KMOD_REC_HOLD = 7,
	/*
	 * a process of `task` (pid, uid) would have opened a
	 * session while the module had no room for one more
	 * (its `max_sessions` open, or no memory): its call was
	 * refused with EAGAIN. count = calls of the task so
	 * refused since the last such record (at most one a
	 * second per task), fields[0] = sessions open,
	 * fields[1] = max_sessions. A reader that predates
	 * this type writes it as a `fault` line
	 */
	CONTEGO_KMOD_REC_SESSIONS_FULL = 8,
	/*
	 * a protected adapter went away (why = CONTEGO_KMOD_ADAPTER_REMOVED:
	 * its node is gone, nothing is written to it) or came back
	 * (CONTEGO_KMOD_ADAPTER_ADDED: its node is back, and the safe state
	 * of its devices follows). bus = the policy's bus, count = the
	 * adapter's number. A reader that predates this type writes it as a
	 * `fault` line
	 */
	CONTEGO_KMOD_REC_ADAPTER = 9,
	/*
	 * a call refused with EOPNOTSUPP before anything of it acted: a
	 * part of what its verdicts would send (a substitute, or the core's
	 * register-by-register writes) has no form on the adapter, as the
	 * monitor's `inexpressible`. task, pid, uid: the caller; bus: the
	 * policy's; addr: the part's; reason: the planner's refusal (enum
	 * contego_i2c_refusal, contego/i2c_plan.h); index: the part's
	 * messages (1, or 2: a write and the read answering it); fields[0]
	 * and [1]: each message's len << 16 | flags; [2]: the adapter's
	 * I2C_FUNCS; [3]: the refused message flags; [4]: the forms it
	 * lacks, candidates_read | count << 8 | size0 << 16 | size1 << 24;
	 * [5]: size2. A reader that predates this type writes it as a
	 * `fault` line
	 */
	CONTEGO_KMOD_REC_INEXPRESSIBLE = 10,
	/*
	 * an operator's reset of a latched device (CONTEGO_KMOD_RESET):
	 * pid, uid: who asked; device, bus, addr: the device; index: 1 if it
	 * was latched. A reader that predates this type writes it as a
	 * `fault` line
	 */
	CONTEGO_KMOD_REC_RESET = 11,
};

enum contego_kmod_adapter_why {
	CONTEGO_KMOD_ADAPTER_REMOVED = 1,
	CONTEGO_KMOD_ADAPTER_ADDED = 2,
};

enum contego_kmod_safe_why {
	CONTEGO_KMOD_SAFE_LOAD = 1, /* a policy was loaded */
	CONTEGO_KMOD_SAFE_UNRECORDED = 2, /* a record could not be taken: failing closed */
	CONTEGO_KMOD_SAFE_TRANSFER = 3, /* a fail-safe inside a transfer of several messages */
	CONTEGO_KMOD_SAFE_UNLOAD = 4, /* the module is being unloaded */
	/*
	 * a session of `task` ended (docs/kernel-client.md
	 * "Sessions"): pid/uid are the process's, count its
	 * wait status, index 1 if the end waited for its
	 * process group's leader, fields[0] the register
	 * writes it staged and never completed (dropped)
	 */
	CONTEGO_KMOD_SAFE_EXIT = 5,
	CONTEGO_KMOD_SAFE_ADAPTER = 6, /* the device's adapter came back */
	CONTEGO_KMOD_SAFE_FAILED = 0x80, /* or'ed in: the safe state could not be written */
};

/* A decision taken in complain mode: the policy's verdict, recorded; the
 * command acted as the program sent it.
 */
#define CONTEGO_KMOD_REC_COMPLAIN 0x1

#define CONTEGO_KMOD_REC_BYTES 24 /* bytes of the command (and substitute) kept */

struct contego_kmod_record {
	__u64 seq; /* 1, 2, 3, ...: consecutive, never reused while the module lives */
	__u64 time_us; /* CLOCK_MONOTONIC (ktime_get_ns() / 1000), the core's now */
	__u32 pid; /* the caller's thread group (0: the module itself) */
	__u32 uid; /* its effective uid */
	__u8 type; /* enum contego_kmod_record_type */
	__u8 decision;
	__u8 reason;
	__u8 rule_kind;
	__u16 task;
	__u16 device;
	__u16 command;
	__u16 rule;
	__u32 job;
	__u8 bus;
	__u8 index;
	__u8 field_count;
	__u8 why; /* SAFE_STATE: enum contego_kmod_safe_why */
	__u16 addr;
	__u16 original_len; /* the command's length (bytes kept: at most CONTEGO_KMOD_REC_BYTES) */
	__u16 substitute_len; /* the substitute's length */
	__u16 flags; /* DECISION: CONTEGO_KMOD_REC_COMPLAIN */
	__u32 count; /* GAP: records lost; LOAD: image bytes; SAFE_STATE/EXIT: wait status */
	__s32 fields[8];
	__u8 original[CONTEGO_KMOD_REC_BYTES];
	__u8 substitute[CONTEGO_KMOD_REC_BYTES];
};

#define CONTEGO_KMOD_IOC_MAGIC 0xC7
#define CONTEGO_KMOD_LOAD _IOWR(CONTEGO_KMOD_IOC_MAGIC, 1, struct contego_kmod_load)
#define CONTEGO_KMOD_STATS _IOR(CONTEGO_KMOD_IOC_MAGIC, 2, struct contego_kmod_stats)
#define CONTEGO_KMOD_RELOAD _IOWR(CONTEGO_KMOD_IOC_MAGIC, 4, struct contego_kmod_reload)
#define CONTEGO_KMOD_IMAGE _IOWR(CONTEGO_KMOD_IOC_MAGIC, 5, struct contego_kmod_image)
#define CONTEGO_KMOD_RESET _IOWR(CONTEGO_KMOD_IOC_MAGIC, 6, struct contego_kmod_reset)
/* On /dev/contego-audit: records up to and including *arg are stored. */
#define CONTEGO_KMOD_AUDIT_ACK _IOW(CONTEGO_KMOD_IOC_MAGIC, 3, __u64)

#endif /* _UAPI_LINUX_CONTEGO_KMOD_H */
