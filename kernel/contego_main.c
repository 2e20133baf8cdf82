// SPDX-License-Identifier: GPL-2.0
/*
 * contego.ko: the checked i2c-dev (docs/kernel-client.md).
 *
 * It takes i2c-dev's place (character major 89, class "i2c-dev", nodes
 * /dev/i2c-N) for the adapters it is told to protect, so unmodified programs
 * opening /dev/i2c-N are checked with no help from them: every write, read,
 * I2C_RDWR and I2C_SMBUS is copied from user memory once, turned into the
 * trusted core's transactions (the same normalisation as contego's gate,
 * docs/gate-protocol.md "Normalisation"), decided by the core -- the same
 * sources as user space, compiled with the kernel's flags -- and only what the
 * core allowed or substituted reaches the adapter.
 *
 * Policy: /dev/contego (root only) takes a compiled image with the
 * CONTEGO_KMOD_LOAD ioctl; the core's verifier checks it in a fresh checker
 * before it replaces the one in force, so a bad image is refused and the old
 * one stays. Until an image is loaded, and for a process no binding names,
 * the core answers its default: deny.
 */
#include <linux/cdev.h>
#include <linux/cgroup.h>
#include <linux/compat.h>
#include <linux/cred.h>
#include <linux/hrtimer.h>
#include <linux/device.h>
#include <linux/fs.h>
#include <linux/file.h>
#include <linux/sched/mm.h>
#include <linux/stat.h>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <linux/init.h>
#include <linux/ktime.h>
#include <linux/math64.h>
#include <linux/miscdevice.h>
#include <linux/mm.h>
#include <linux/module.h>
#include <linux/mutex.h>
#include <linux/nsproxy.h>
#include <linux/pid.h>
#include <linux/poll.h>
#include <linux/sched.h>
#include <linux/sched/signal.h>
#include <linux/slab.h>
#include <linux/spinlock.h>
#include <linux/uaccess.h>
#include <linux/version.h>
#include <linux/vmalloc.h>
#include <linux/wait.h>
#include <linux/workqueue.h>

#include "contego/core_c.h"
#include "contego/i2c_msg_flags.h"
#include "contego_kmod.h"

#define CT_MAX_ADAPTERS 8
#define CT_MAX_MSGS I2C_RDWR_IOCTL_MAX_MSGS /* 42 */
#define CT_MAX_LEN 8192
#define CT_MAX_SAMPLE 64 /* contego::core::kMaxSampleBytes */

static int adapters[CT_MAX_ADAPTERS];
static int n_adapters;
module_param_array(adapters, int, &n_adapters, 0444);
MODULE_PARM_DESC(adapters, "adapter numbers to protect (/dev/i2c-N); default 0");
static int buses[CT_MAX_ADAPTERS];
static int n_buses;
module_param_array(buses, int, &n_buses, 0444);
MODULE_PARM_DESC(buses, "the policy's bus number of each protected adapter (`at i2c-B`); default: the adapter's number");

static bool trace;
module_param(trace, bool, 0644);
MODULE_PARM_DESC(trace, "log every decision to the kernel log (debugging; not the audit log)");

static unsigned int audit_records = 16384;
module_param(audit_records, uint, 0444);
MODULE_PARM_DESC(audit_records, "records the audit ring holds until the reader acknowledges them");

static unsigned int max_sessions = 1024;
module_param(max_sessions, uint, 0444);
MODULE_PARM_DESC(max_sessions, "sessions open at once, all tasks together; a call that would open one more is refused (EAGAIN)");

/* ---- the checker in force ---------------------------------------------- */

/* The latest sample of a sensor (the core's read_sample host callback). */
struct ct_sample {
	u64 taken_us;
	u32 len;
	bool valid; /* false: none yet, or the last read failed */
	u8 bytes[CT_MAX_SAMPLE];
};

struct ct_policy {
	u64 gen; /* which load: sessions opened under an older one end without acting */
	void *mem; /* checker storage, contego_checker_size() bytes */
	contego_checker *checker;
	u8 *image; /* the verified image, kept for the checker's lifetime */
	u32 size;  /* its bytes */
	u32 nbinds;
	struct contego_kmod_bind binds[CONTEGO_KMOD_MAX_BINDS];
	/* The job grid of each task (as the monitor's job_at_locked): phase =
	 * its first transaction; job k spans [phase + (k-1)*period, phase + k*period). */
	u64 phase_us[32];
	u32 phase_set; /* bit per task */
	struct ct_sample samples[32];
	/* What the monitor enforces beside the image (from CONTEGO_KMOD_LOAD):
	 * each task's live sessions and actuations per job, and the hold. */
	u32 sessions[CONTEGO_KMOD_MAX_TASKS];
	u32 actuations[CONTEGO_KMOD_MAX_TASKS];
	u32 budget_factor;
	u32 complain; /* bit per task: complain mode (docs/learn.md) */
	u8 ignore_errno[CONTEGO_KMOD_MAX_TASKS]; /* the policy's `ignore_errno`, 0: none */
	/* The over-budget hold (as the monitor's hold_if_over_budget): the
	 * job each task's budget counts, and the transfers charged to it. */
	u32 budget_job[CONTEGO_KMOD_MAX_TASKS];
	u32 budget_used[CONTEGO_KMOD_MAX_TASKS];
	u32 holds_unreported[CONTEGO_KMOD_MAX_TASKS];
	u64 hold_reported_us[CONTEGO_KMOD_MAX_TASKS];
	u32 hold_told; /* bit per task: the first hold is in the kernel log */
	/* Calls refused for want of room for a session (max_sessions), as
	 * the holds: audited at most once a second per task. */
	u32 full_unreported[CONTEGO_KMOD_MAX_TASKS];
	u64 full_reported_us[CONTEGO_KMOD_MAX_TASKS];
};

/* One decision at a time (the core is not thread-safe): the lock covers the
 * checks of a call and its bus operations, as the user-space monitor's does. */
static DEFINE_MUTEX(ct_lock);
static bool ct_complain_now; /* under ct_lock: the call being decided complains */
static struct ct_policy *ct_policy;
static u64 ct_gen; /* under ct_lock: loads so far */
static struct contego_kmod_stats ct_stats;
/* Scratch for one call, under ct_lock (kept off the 16 KiB kernel stack). */
static contego_verdict ct_verdicts[CT_MAX_MSGS];
static contego_verdict ct_safe_verdict;

struct ct_tx {
	u8 kind;
	u16 addr;
	bool ten;
	u32 len;
	const u8 *bytes;
	u32 first_msg, msg_count; /* messages covered (RDWR) */
};

static struct ct_tx ct_txs[CT_MAX_MSGS];

/* ---- protected adapters -------------------------------------------------- */

struct ct_node {
	int nr;  /* adapter number */
	u8 bus;  /* policy bus */
	struct cdev cdev;
	struct device *dev;
	bool registered;
};
static struct ct_node ct_nodes[CT_MAX_ADAPTERS];
static int ct_node_count;
static struct class *ct_class;

/*
 * The nodes are open to every user: the module, not the file mode, decides
 * who may act (an unbound process gets the policy's default). CONTEGO_KMOD=1
 * in the uevent lets udev rules tell these nodes from i2c-dev's (the
 * package's rule hands i2c-dev's to the monitor alone, and keeps off these).
 */
#if LINUX_VERSION_CODE >= KERNEL_VERSION(6, 2, 0)
#define CT_CLASS_DEV const struct device
#else
#define CT_CLASS_DEV struct device
#endif
static char *ct_devnode(CT_CLASS_DEV *dev, umode_t *mode)
{
	if (mode)
		*mode = 0666;
	return NULL;
}

static int ct_dev_uevent(CT_CLASS_DEV *dev, struct kobj_uevent_env *env)
{
	return add_uevent_var(env, "CONTEGO_KMOD=1");
}

struct ct_file {
	struct i2c_adapter *adap;
	u8 bus;
	u16 addr;
	u16 flags; /* I2C_M_TEN, I2C_CLIENT_PEC */
};

static struct ct_node *ct_node_for_bus(u8 bus)
{
	int i;

	for (i = 0; i < ct_node_count; i++)
		if (ct_nodes[i].bus == bus)
			return &ct_nodes[i];
	return NULL;
}

static u32 ct_job(struct ct_policy *p, u16 task, u64 now)
{
	u32 period = task < 32 ? contego_task_period_us(p->checker, task) : 0;

	if (period == 0)
		return 0; /* no task: the core's own windows */
	if (!(p->phase_set & (1u << task))) {
		p->phase_set |= 1u << task;
		p->phase_us[task] = now;
	}
	if (now <= p->phase_us[task])
		return 1;
	return (u32)div64_u64(now - p->phase_us[task], period) + 1;
}

/* Scratch for the caller's cgroup path, under ct_lock. */
static char ct_cgroup_buf[PATH_MAX];

/* The caller's cgroup v2 path into ct_cgroup_buf, as the initial cgroup
 * namespace sees it (a process cannot move its own root with a namespace of
 * its own). task_cgroup_path() would give a v1 hierarchy's path. */
static bool ct_current_cgroup_path(void)
{
	struct cgroup *cgrp;
	int ret;

	rcu_read_lock();
	cgrp = task_dfl_cgroup(current);
	cgroup_get(cgrp);
	rcu_read_unlock();
	ret = cgroup_path_ns(cgrp, ct_cgroup_buf, sizeof(ct_cgroup_buf),
			     init_task.nsproxy->cgroup_ns);
	cgroup_put(cgrp);
	return ret >= 0 && ret < (int)sizeof(ct_cgroup_buf);
}

/* Whether `path` is `cg` or below it. */
static bool ct_cgroup_under(const char *path, const char *cg)
{
	size_t n = strlen(cg);

	if (strcmp(cg, "/") == 0)
		return true;
	return strncmp(path, cg, n) == 0 && (path[n] == '\0' || path[n] == '/');
}

/* Whether a component of `path` is `unit`. */
static bool ct_cgroup_has_unit(const char *path, const char *unit)
{
	size_t n = strlen(unit);
	const char *c = path;

	while ((c = strstr(c, unit)) != NULL) {
		if ((c == path || c[-1] == '/') && (c[n] == '\0' || c[n] == '/'))
			return true;
		c += n;
	}
	return false;
}

/* Whether the caller runs the executable (dev, ino) -- as stat(2) of it says. */
static bool ct_current_exe_is(const struct contego_kmod_bind *b)
{
	struct mm_struct *mm = current->mm;
	struct file *exe = NULL;
	struct kstat st;
	bool same = false;

	/* get_mm_exe_file() is not exported: its RCU read, here (our own mm). */
	if (!mm)
		return false;
	rcu_read_lock();
#if LINUX_VERSION_CODE >= KERNEL_VERSION(6, 7, 0)
	exe = get_file_rcu(&mm->exe_file); /* 6.7 made it take the RCU pointer */
#else
	exe = rcu_dereference(mm->exe_file);
	if (exe && !get_file_rcu(exe))
		exe = NULL;
#endif
	rcu_read_unlock();
	if (!exe)
		return false;
	if (vfs_getattr(&exe->f_path, &st, STATX_INO, AT_STATX_SYNC_AS_STAT) == 0)
		same = st.ino == b->exe_ino && MAJOR(st.dev) == b->exe_major &&
		       MINOR(st.dev) == b->exe_minor;
	fput(exe);
	return same;
}

/* The caller's task: the first binding whose every fact it meets. Under ct_lock. */
static u16 ct_task_of_current(const struct ct_policy *p)
{
	u32 uid = from_kuid(&init_user_ns, current_euid());
	bool have_cgroup = false, cgroup_known = false;
	u32 i;

	for (i = 0; i < p->nbinds; i++) {
		const struct contego_kmod_bind *b = &p->binds[i];

		if (b->uid != CONTEGO_KMOD_ANY && b->uid != uid)
			continue;
		if (b->gid != CONTEGO_KMOD_ANY && !in_egroup_p(make_kgid(&init_user_ns, b->gid)))
			continue;
		if ((b->flags & CONTEGO_KMOD_BIND_EXE) && !ct_current_exe_is(b))
			continue;
		if (b->cgroup[0] || b->unit[0]) {
			if (!have_cgroup) {
				have_cgroup = true;
				cgroup_known = ct_current_cgroup_path();
			}
			if (!cgroup_known)
				continue;
			if (b->cgroup[0] && !ct_cgroup_under(ct_cgroup_buf, b->cgroup))
				continue;
			if (b->unit[0] && !ct_cgroup_has_unit(ct_cgroup_buf, b->unit))
				continue;
		}
		return b->task;
	}
	return CONTEGO_NONE;
}

/* ---- the audit ring ------------------------------------------------------ */

/* Records seq acked+1 .. head are in the ring (record s at (s - 1) % cap).
 * ct_ring_lock covers the ring, the reader flag and the gap count; the
 * producers also hold ct_lock (one decision at a time). */
static struct contego_kmod_record *ct_ring;
static u32 ct_ring_cap;
static u64 ct_head, ct_acked;
static bool ct_reader;
static u64 ct_gap; /* records lost since the last one taken */
static DEFINE_SPINLOCK(ct_ring_lock);
static DECLARE_WAIT_QUEUE_HEAD(ct_ring_wait);
/* Set by the core's audit callback when a record of the call in progress
 * could not be taken (under ct_lock). */
static bool ct_audit_lost;

/* Takes one record (seq assigned here), first the gap record if records were
 * lost before it. False: not taken (no reader, the ring full); it is counted
 * in the gap. A record of something that acts nothing (a refused or ignored
 * command, `acting` false) may use only three quarters of the ring: a flood
 * of refused calls cannot take the room the records of actions need. */
static bool ct_push(struct contego_kmod_record *r, bool acting)
{
	unsigned long flags;
	u32 room;
	bool ok;

	spin_lock_irqsave(&ct_ring_lock, flags);
	room = ct_ring_cap - (u32)(ct_head - ct_acked);
	if (!acting)
		room = room > ct_ring_cap / 4 ? room - ct_ring_cap / 4 : 0;
	ok = ct_reader && room >= (ct_gap ? 2u : 1u);
	if (ok && ct_gap) {
		struct contego_kmod_record *g = &ct_ring[ct_head % ct_ring_cap];

		memset(g, 0, sizeof(*g));
		g->seq = ++ct_head;
		g->time_us = r->time_us;
		g->type = CONTEGO_KMOD_REC_GAP;
		g->count = (u32)min_t(u64, ct_gap, U32_MAX);
		ct_gap = 0;
	}
	if (ok) {
		r->seq = ++ct_head;
		ct_ring[(r->seq - 1) % ct_ring_cap] = *r;
		ct_stats.records++;
	} else {
		ct_gap++;
		ct_stats.unrecorded++;
	}
	spin_unlock_irqrestore(&ct_ring_lock, flags);
	if (ok)
		wake_up_interruptible(&ct_ring_wait);
	return ok;
}

static void ct_record_start(struct contego_kmod_record *r, u8 type, bool caller)
{
	memset(r, 0, sizeof(*r));
	r->type = type;
	r->time_us = div_u64(ktime_get_ns(), 1000);
	r->task = CONTEGO_NONE;
	r->device = CONTEGO_NONE;
	r->command = CONTEGO_NONE;
	r->rule = CONTEGO_NONE;
	if (caller) {
		r->pid = task_tgid_nr(current);
		r->uid = from_kuid(&init_user_ns, current_euid());
	}
}

/* The core's audit host callback: one record per decoded command, inside
 * contego_check (under ct_lock). */
static void ct_audit(void *context, const contego_audit_record *a)
{
	struct contego_kmod_record r;
	u32 n;

	ct_record_start(&r, CONTEGO_KMOD_REC_DECISION, true);
	if (ct_complain_now)
		r.flags = CONTEGO_KMOD_REC_COMPLAIN;
	r.time_us = a->time_us;
	r.job = a->job;
	r.task = a->task;
	r.device = a->device;
	r.command = a->command;
	r.rule = a->rule;
	r.rule_kind = a->rule_kind;
	r.decision = a->decision;
	r.reason = a->reason;
	r.index = a->index;
	r.field_count = min_t(u8, a->field_count, ARRAY_SIZE(r.fields));
	memcpy(r.fields, a->fields, r.field_count * sizeof(r.fields[0]));
	r.bus = a->bus;
	r.addr = a->addr;
	r.original_len = a->original_len;
	n = min_t(u32, a->original_len, CONTEGO_KMOD_REC_BYTES);
	if (a->original && n)
		memcpy(r.original, a->original, n);
	r.substitute_len = a->substitute ? a->substitute_len : 0;
	n = min_t(u32, r.substitute_len, CONTEGO_KMOD_REC_BYTES);
	if (a->substitute && n)
		memcpy(r.substitute, a->substitute, n);
	/* Nothing acts unrecorded: only a command that may act (allowed, or
	 * replaced by a substitute) fails its call when its record is lost; a
	 * refused or ignored one is counted in the gap and refused or ignored
	 * all the same. */
	if (!ct_push(&r, a->decision == CONTEGO_ALLOW || a->decision == CONTEGO_FAILSAFE))
		ct_audit_lost |= a->decision == CONTEGO_ALLOW || a->decision == CONTEGO_FAILSAFE;
}

/* ---- bus operations ------------------------------------------------------ */

/* One write of `len` bytes at `addr`: a plain I2C message when the adapter
 * has I2C_FUNC_I2C, else the SMBus transaction with the same wire bytes
 * (src/bus/smbus_plan.h's forms). */
static int ct_write_bytes(struct i2c_adapter *adap, u16 addr, u16 flags, const u8 *b, u32 len)
{
	u32 funcs = i2c_get_functionality(adap);
	union i2c_smbus_data data;
	int ret;

	if (funcs & I2C_FUNC_I2C) {
		struct i2c_msg m = { .addr = addr, .flags = flags & I2C_M_TEN, .len = len,
				     .buf = (u8 *)b };

		ret = i2c_transfer(adap, &m, 1);
		return ret == 1 ? 0 : (ret < 0 ? ret : -EIO);
	}
	if (flags & I2C_M_TEN)
		return -EOPNOTSUPP;
	flags &= I2C_CLIENT_PEC;
	switch (len) {
	case 0:
		return i2c_smbus_xfer(adap, addr, flags, I2C_SMBUS_WRITE, 0, I2C_SMBUS_QUICK, NULL);
	case 1:
		return i2c_smbus_xfer(adap, addr, flags, I2C_SMBUS_WRITE, b[0], I2C_SMBUS_BYTE, NULL);
	case 2:
		data.byte = b[1];
		return i2c_smbus_xfer(adap, addr, flags, I2C_SMBUS_WRITE, b[0],
				      I2C_SMBUS_BYTE_DATA, &data);
	case 3:
		data.word = b[1] | (b[2] << 8);
		return i2c_smbus_xfer(adap, addr, flags, I2C_SMBUS_WRITE, b[0],
				      I2C_SMBUS_WORD_DATA, &data);
	default:
		if (len > 1 + I2C_SMBUS_BLOCK_MAX || !(funcs & I2C_FUNC_SMBUS_WRITE_I2C_BLOCK))
			return -EOPNOTSUPP;
		data.block[0] = len - 1;
		memcpy(&data.block[1], b + 1, len - 1);
		return i2c_smbus_xfer(adap, addr, flags, I2C_SMBUS_WRITE, b[0],
				      I2C_SMBUS_I2C_BLOCK_DATA, &data);
	}
}

/* The writes a verdict allows or substitutes, in order, at the verdict's address. */
static int ct_perform_emits(struct i2c_adapter *adap, const contego_verdict *v, u16 flags)
{
	u32 off = 0, i;
	int ret;

	for (i = 0; i < v->emit_count && i < CONTEGO_MAX_EMITS; i++) {
		u32 len = v->emit_len[i];

		if (off + len > CONTEGO_MAX_EMIT_BYTES)
			return -EIO; /* malformed verdict: fail closed */
		ret = ct_write_bytes(adap, v->addr, flags, v->emit_bytes + off, len);
		if (ret < 0)
			return ret;
		off += len;
	}
	return 0;
}

/* Whether the verdict writes exactly the requested bytes, once. */
static bool ct_emits_are(const contego_verdict *v, const u8 *b, u32 len, u16 addr)
{
	return v->emit_count == 1 && v->emit_len[0] == len && v->addr == addr &&
	       (len == 0 || memcmp(v->emit_bytes, b, len) == 0);
}

/* ---- sensor samples (the core's read_sample host) ------------------------ */

/* Reads a sample of `info`'s sensor into buf (info->sample_len bytes), as the
 * monitor's sample_device_locked does: the sample request written, then the
 * sample read. An adapter without plain I2C reads a one-byte request's
 * register in one SMBus transaction (register, repeated start, read):
 * byte data, word data or an I2C block read (src/bus/smbus_plan.h). */
static int ct_read_sample_bus(struct i2c_adapter *adap, const contego_device_info *info, u8 *buf)
{
	u32 funcs = i2c_get_functionality(adap);
	u16 ten = info->ten_bit ? I2C_M_TEN : 0;
	u8 n = info->sample_len, reg = info->sample_request[0];
	union i2c_smbus_data data;
	int ret;

	if (funcs & I2C_FUNC_I2C) {
		struct i2c_msg m = { .addr = info->addr, .flags = ten | I2C_M_RD, .len = n, .buf = buf };

		if (info->sample_request_len) {
			ret = ct_write_bytes(adap, info->addr, ten, info->sample_request,
					     info->sample_request_len);
			if (ret < 0)
				return ret;
		}
		ret = i2c_transfer(adap, &m, 1);
		return ret == 1 ? 0 : (ret < 0 ? ret : -EIO);
	}
	if (ten)
		return -EOPNOTSUPP;
	if (info->sample_request_len == 1) {
		if (n == 1 && (funcs & I2C_FUNC_SMBUS_READ_BYTE_DATA)) {
			ret = i2c_smbus_xfer(adap, info->addr, 0, I2C_SMBUS_READ, reg,
					     I2C_SMBUS_BYTE_DATA, &data);
			if (ret == 0)
				buf[0] = data.byte;
			return ret;
		}
		if (n == 2 && (funcs & I2C_FUNC_SMBUS_READ_WORD_DATA)) {
			ret = i2c_smbus_xfer(adap, info->addr, 0, I2C_SMBUS_READ, reg,
					     I2C_SMBUS_WORD_DATA, &data);
			if (ret == 0) {
				buf[0] = data.word & 0xff;
				buf[1] = data.word >> 8;
			}
			return ret;
		}
		if (n <= I2C_SMBUS_BLOCK_MAX && (funcs & I2C_FUNC_SMBUS_READ_I2C_BLOCK)) {
			data.block[0] = n;
			ret = i2c_smbus_xfer(adap, info->addr, 0, I2C_SMBUS_READ, reg,
					     I2C_SMBUS_I2C_BLOCK_DATA, &data);
			if (ret < 0)
				return ret;
			if (data.block[0] < n)
				return -EIO;
			memcpy(buf, &data.block[1], n);
			return 0;
		}
		return -EOPNOTSUPP;
	}
	/* A longer request (or none) on its own, then a read without a pointer:
	 * one byte is all SMBus can receive that way. */
	if (n != 1 || !(funcs & I2C_FUNC_SMBUS_READ_BYTE))
		return -EOPNOTSUPP;
	if (info->sample_request_len) {
		ret = ct_write_bytes(adap, info->addr, 0, info->sample_request,
				     info->sample_request_len);
		if (ret < 0)
			return ret;
	}
	ret = i2c_smbus_xfer(adap, info->addr, 0, I2C_SMBUS_READ, 0, I2C_SMBUS_BYTE, &data);
	if (ret == 0)
		buf[0] = data.byte;
	return ret;
}

/* Samples sensor d now. A read that fails leaves no sample: the sensor's
 * signals are unavailable (fail closed) until a later read succeeds. Under
 * ct_lock. */
static void ct_sample_device(struct ct_policy *p, u16 d, const contego_device_info *info, u64 now)
{
	struct ct_sample *s = &p->samples[d];
	struct ct_node *node = ct_node_for_bus(info->bus);
	struct i2c_adapter *adap = node ? i2c_get_adapter(node->nr) : NULL;
	int ret = -ENODEV;

	s->valid = false;
	if (adap) {
		ret = ct_read_sample_bus(adap, info, s->bytes);
		i2c_put_adapter(adap);
	}
	if (ret < 0) {
		ct_stats.sample_errors++;
		pr_warn_ratelimited("contego: sample of device %u (bus %u 0x%02x) failed: %d; its signals are unavailable\n",
				    d, info->bus, info->addr, ret);
		return;
	}
	ct_stats.samples++;
	s->len = info->sample_len;
	s->taken_us = now;
	s->valid = true;
}

/* The core's read_sample host callback, inside contego_check or
 * contego_safe_state (under ct_lock, process context: the bus may sleep).
 * The sample is never older than the device's sample period, as with the
 * monitor's periodic sampling: an older one is read again first. The
 * core applies `max_age` to what it is given. */
static u32 ct_read_sample(void *context, u16 device, u8 *buf, u32 capacity, u64 *taken_at_us)
{
	struct ct_policy *p = context;
	contego_device_info info;
	struct ct_sample *s;
	u64 now = div_u64(ktime_get_ns(), 1000);
	u32 n;

	if (!p || device >= ARRAY_SIZE(p->samples) ||
	    !contego_device_info_of(p->checker, device, &info) ||
	    !(info.role & CONTEGO_ROLE_SENSOR) || info.sample_len == 0 ||
	    info.sample_len > CT_MAX_SAMPLE)
		return 0;
	s = &p->samples[device];
	if (!s->valid || now < s->taken_us || now - s->taken_us >= info.sample_period_us)
		ct_sample_device(p, device, &info, now);
	if (!s->valid)
		return 0;
	n = min_t(u32, capacity, s->len);
	memcpy(buf, s->bytes, n);
	if (taken_at_us)
		*taken_at_us = s->taken_us;
	return n;
}

struct ct_session;
static void ct_session_record(struct contego_kmod_record *r, const struct ct_session *s);

/* Device d's declared safe state, written and recorded (best effort: the
 * record may be lost, then counted in the gap). `s`: the session whose end
 * drives it (its task and process go into the record), or NULL. Under
 * ct_lock. 1: written; 0: the write failed; -1: d has no safe state. */
static int ct_drive_safe_state_of(struct ct_policy *p, u16 d, u8 why, const struct ct_session *s)
{
	struct contego_kmod_record r;
	struct ct_node *node;
	struct i2c_adapter *adap;
	bool done = false;

	if (!contego_safe_state(p->checker, d, &ct_safe_verdict))
		return -1;
	node = ct_node_for_bus(ct_safe_verdict.bus);
	adap = node ? i2c_get_adapter(node->nr) : NULL;
	if (adap) {
		done = ct_perform_emits(adap, &ct_safe_verdict, 0) == 0;
		i2c_put_adapter(adap);
	}
	if (!done)
		pr_warn("contego: safe state of device %u failed\n", d);
	ct_record_start(&r, CONTEGO_KMOD_REC_SAFE_STATE, why != CONTEGO_KMOD_SAFE_UNLOAD &&
							    why != CONTEGO_KMOD_SAFE_LOAD);
	r.device = d;
	r.bus = ct_safe_verdict.bus;
	r.addr = ct_safe_verdict.addr;
	r.why = why | (done ? 0 : CONTEGO_KMOD_SAFE_FAILED);
	r.substitute_len = ct_safe_verdict.emit_bytes_used;
	memcpy(r.substitute, ct_safe_verdict.emit_bytes,
	       min_t(u32, ct_safe_verdict.emit_bytes_used, CONTEGO_KMOD_REC_BYTES));
	if (s)
		ct_session_record(&r, s);
	ct_push(&r, true);
	return done;
}

static bool ct_drive_safe_state(struct ct_policy *p, u16 d, u8 why)
{
	return ct_drive_safe_state_of(p, d, why, NULL) > 0;
}

/* Every device's safe state. Under ct_lock. Returns how many were written. */
static u32 ct_drive_safe_states(struct ct_policy *p, u8 why)
{
	u32 n = 0;
	u16 d;

	for (d = 0; d < 32; d++)
		n += ct_drive_safe_state(p, d, why);
	return n;
}

/* ---- sessions (docs/kernel-client.md "Sessions") ------------------------- */

/* A session of task T is a process (thread group) that made a call the core
 * checked as T. It ends when the process exits -- not when it closes the
 * node -- and its end drives T's actuators (the image's access matrix, as
 * the monitor's task_exited) to their safe state. A process that exits with
 * status 0 and is not its process group's leader, while that leader lives,
 * hands its end to the leader: the i2cset runs of a shell script are one
 * session, ended with the script. Killed by a signal, crashed, or exited
 * with an error, a process ends its session at once.
 *
 * The exit is seen on the process's struct pid (the wait queue pidfds poll,
 * woken by do_notify_pidfd() under tasklist_lock: atomic), which only queues
 * the session's work; the safe state is driven from the work, in process
 * context, under ct_lock. The unload takes every session off its wait queue
 * and drains the work before the checker and the module go. */
enum { CT_S_PROCESS = 0, CT_S_LEADER = 1 };

struct ct_session {
	struct list_head node; /* ct_sessions, under ct_lock */
	u64 gen;               /* the load it was opened under */
	u16 task;
	u8 phase;   /* CT_S_*: whose exit ends it */
	bool fired; /* its watch exited: the work owns it (under the wait queue's lock) */
	u32 pid, uid; /* the process, as the records name it */
	u32 status;   /* its wait status */
	u32 staged_dropped; /* at its end: register writes staged, never completed */
	struct pid *proc;   /* the process (thread group) */
	struct pid *watch;  /* whose exit ends it: proc, then perhaps its group's leader */
	struct pid *leader; /* set when fired: hand the end to this leader */
	struct wait_queue_entry wq;
	struct work_struct work;
};

static LIST_HEAD(ct_sessions);
static u32 ct_session_count;       /* under ct_lock */
static struct workqueue_struct *ct_wq;
static bool ct_unloading;          /* under ct_lock */

static void ct_session_record(struct contego_kmod_record *r, const struct ct_session *s)
{
	r->task = s->task;
	r->pid = s->pid;
	r->uid = s->uid;
	r->count = s->status;
	r->index = s->phase == CT_S_LEADER;
	r->fields[0] = (s32)s->staged_dropped;
	r->field_count = 1;
}

/*
 * Whether every thread of the process `pid` led has exited: what pidfd's
 * poll reports. 6.1's thread_group_exited(), which later kernels dropped
 * (their pidfd_poll() asks the task the same), written out here.
 */
static bool ct_thread_group_exited(struct pid *pid)
{
	struct task_struct *task;
	bool exited;

	rcu_read_lock();
	task = pid_task(pid, PIDTYPE_PID);
	exited = !task || (READ_ONCE(task->exit_state) && thread_group_empty(task));
	rcu_read_unlock();
	return exited;
}

/* do_notify_pidfd()'s wake-up of the watched pid: atomic context (the wait
 * queue's lock and tasklist_lock are held). Notes how the process ended and
 * queues the work; nothing here sleeps or touches the bus. */
static int ct_session_wake(struct wait_queue_entry *wq, unsigned int mode, int sync, void *key)
{
	struct ct_session *s = container_of(wq, struct ct_session, wq);
	struct task_struct *t;
	struct pid *pg;

	if (s->fired || !ct_thread_group_exited(s->watch))
		return 0;
	s->fired = true;
	list_del_init(&wq->entry);
	if (s->phase == CT_S_PROCESS) {
		rcu_read_lock();
		t = pid_task(s->watch, PIDTYPE_TGID);
		if (t) {
			s->status = (t->signal->flags & SIGNAL_GROUP_EXIT) ?
					    t->signal->group_exit_code : t->exit_code;
			pg = task_pgrp(t);
			if (s->status == 0 && pg && pg != s->watch && !ct_thread_group_exited(pg))
				s->leader = get_pid(pg);
		}
		rcu_read_unlock();
	}
	queue_work(ct_wq, &s->work);
	return 1;
}

static void ct_session_arm(struct ct_session *s)
{
	s->fired = false;
	init_waitqueue_func_entry(&s->wq, ct_session_wake);
	add_wait_queue(&s->watch->wait_pidfd, &s->wq);
}

/* Takes s off its wait queue unless its wake-up came first. True: taken
 * (nobody else will queue its work). */
static bool ct_session_disarm(struct ct_session *s)
{
	unsigned long flags;
	bool taken;

	spin_lock_irqsave(&s->watch->wait_pidfd.lock, flags);
	taken = !s->fired;
	if (taken) {
		s->fired = true;
		list_del_init(&s->wq.entry);
	}
	spin_unlock_irqrestore(&s->watch->wait_pidfd.lock, flags);
	return taken;
}

static void ct_session_free(struct ct_session *s)
{
	put_pid(s->leader);
	put_pid(s->watch);
	put_pid(s->proc);
	kfree(s);
}

/* The end of s: its task's actuators to their safe state. Under ct_lock. */
static void ct_session_end(struct ct_policy *p, struct ct_session *s)
{
	u32 mask = contego_task_actuates(p->checker, s->task), n = 0, tried = 0;
	u16 d;
	int r;

	/* The session's own state (a sequence's position) ends with it, and
	 * the register writes it staged and never completed are dropped: they
	 * never reached a device (its records say how many). */
	s->staged_dropped = contego_end_session(p->checker, s->task);
	for (d = 0; d < 32; d++) {
		if (!(mask & (1u << d)))
			continue;
		r = ct_drive_safe_state_of(p, d, CONTEGO_KMOD_SAFE_EXIT, s);
		tried += r >= 0;
		n += r > 0;
	}
	if (tried == 0) { /* nothing to drive: the end is recorded all the same */
		struct contego_kmod_record rec;

		ct_record_start(&rec, CONTEGO_KMOD_REC_SAFE_STATE, false);
		rec.why = CONTEGO_KMOD_SAFE_EXIT;
		ct_session_record(&rec, s);
		ct_push(&rec, true);
	}
	ct_stats.session_ends++;
	pr_info("contego: task %u: session of pid %u ended (wait status 0x%x%s): %u of %u devices driven to their safe state\n",
		s->task, s->pid, s->status, s->phase == CT_S_LEADER ? ", with its group's leader" : "",
		n, tried);
}

static void ct_session_work(struct work_struct *w)
{
	struct ct_session *s = container_of(w, struct ct_session, work), *o;
	struct ct_policy *p;

	mutex_lock(&ct_lock);
	if (s->leader && !ct_unloading) {
		struct pid *leader = s->leader;

		s->leader = NULL;
		/* One session per task and group leader: the runs of a script end once. */
		list_for_each_entry(o, &ct_sessions, node) {
			if (o != s && o->phase == CT_S_LEADER && o->watch == leader &&
			    o->task == s->task && o->gen == s->gen) {
				put_pid(leader);
				goto drop;
			}
		}
		put_pid(s->watch);
		s->watch = leader;
		s->phase = CT_S_LEADER;
		ct_session_arm(s);
		/* The leader may have gone meanwhile: then end now, unless its
		 * wake-up already queued this work again. */
		if (!ct_thread_group_exited(leader) || !ct_session_disarm(s)) {
			mutex_unlock(&ct_lock);
			return;
		}
	}
	p = ct_policy;
	if (!ct_unloading && p && p->gen == s->gen)
		ct_session_end(p, s);
drop:
	list_del(&s->node);
	ct_session_count--;
	ct_stats.sessions = ct_session_count;
	mutex_unlock(&ct_lock);
	ct_session_free(s);
}

/* The caller's open session of `task` (NULL: none). Under ct_lock. */
static struct ct_session *ct_session_find(struct ct_policy *p, u16 task)
{
	struct pid *me = task_tgid(current);
	struct ct_session *s;

	list_for_each_entry(s, &ct_sessions, node) {
		if (s->proc == me && s->task == task && s->gen == p->gen && s->phase == CT_S_PROCESS) {
			list_move(&s->node, &ct_sessions); /* the next call finds it first */
			return s;
		}
	}
	return NULL;
}

/* The policy's `sessions` (docs/kernel-client.md "Sessions"): how many live
 * sessions a task may have, as the monitor's admit() counts them. Here a
 * live session is a unit: a process, or the process group whose leader a
 * session was handed to. A process that is not its group's leader, while
 * that leader lives, belongs to the group's unit (its session would end
 * there), so the i2cset runs of a script, or a controller's forked child,
 * are one session, not several. */
static struct pid *ct_unit_of(struct task_struct *t)
{
	struct pid *pg = task_pgrp(t), *me = task_tgid(t);

	return pg && pg != me && !ct_thread_group_exited(pg) ? pg : me;
}

/* The unit of s while it lives; NULL once it has ended or is ending (its
 * process, or its group's leader, exited: its end is queued). Under ct_lock
 * and rcu_read_lock. */
static struct pid *ct_session_unit(struct ct_session *s)
{
	struct task_struct *t;
	struct pid *unit;
	unsigned long flags;

	spin_lock_irqsave(&s->watch->wait_pidfd.lock, flags);
	if (s->phase == CT_S_LEADER) {
		unit = s->fired ? NULL : s->watch;
	} else if (s->fired) {
		/* Handed to its group's leader while that lives, or ending. */
		unit = s->leader && !ct_thread_group_exited(s->leader) ? s->leader : NULL;
	} else {
		t = pid_task(s->proc, PIDTYPE_TGID);
		unit = t ? ct_unit_of(t) : s->proc;
	}
	spin_unlock_irqrestore(&s->watch->wait_pidfd.lock, flags);
	return unit;
}

static struct pid *ct_units[CONTEGO_KMOD_MAX_TASK_SESSIONS]; /* scratch, under ct_lock */

/* Whether the caller may open a session of `task`: its unit already has a
 * live session of the task, or the task has fewer live units than its
 * `sessions`. Under ct_lock. */
static bool ct_session_room(struct ct_policy *p, u16 task)
{
	u32 allowed = task < CONTEGO_KMOD_MAX_TASKS ? p->sessions[task] : 1, n = 0, i;
	struct ct_session *s;
	struct pid *mine, *u;
	bool room;

	rcu_read_lock();
	mine = ct_unit_of(current);
	list_for_each_entry(s, &ct_sessions, node) {
		if (s->task != task || s->gen != p->gen)
			continue;
		u = ct_session_unit(s);
		if (!u)
			continue;
		if (u == mine) { /* one session with it */
			rcu_read_unlock();
			return true;
		}
		for (i = 0; i < n && ct_units[i] != u; i++)
			;
		if (i == n && n < allowed && n < ARRAY_SIZE(ct_units))
			ct_units[n++] = u;
	}
	room = n < allowed;
	rcu_read_unlock();
	return room;
}

/* A session for the caller, made before its call is decided so that a call
 * that would act without one can be refused instead. Under ct_lock. NULL:
 * no room (max_sessions) or no memory. */
static struct ct_session *ct_session_prepare(struct ct_policy *p, u16 task)
{
	struct ct_session *s;

	if (ct_session_count >= max_sessions)
		return NULL;
	s = kzalloc(sizeof(*s), GFP_KERNEL);
	if (!s)
		return NULL;
	s->gen = p->gen;
	s->task = task;
	s->phase = CT_S_PROCESS;
	s->pid = task_tgid_nr(current);
	s->uid = from_kuid(&init_user_ns, current_euid());
	s->proc = get_pid(task_tgid(current));
	s->watch = get_pid(s->proc);
	INIT_WORK(&s->work, ct_session_work);
	return s;
}

/* Opens the prepared session: the caller's call acted. Under ct_lock. */
static void ct_session_open(struct ct_session *s)
{
	list_add(&s->node, &ct_sessions);
	ct_session_count++;
	ct_stats.sessions = ct_session_count;
	/* The caller runs: its thread group cannot have exited yet. */
	ct_session_arm(s);
}

/* The unload: every session off its wait queue, their work drained; the
 * safe state of every device is the unload's own. */
static void ct_sessions_stop(void)
{
	struct ct_session *s, *n;

	mutex_lock(&ct_lock);
	ct_unloading = true;
	list_for_each_entry(s, &ct_sessions, node)
		ct_session_disarm(s);
	mutex_unlock(&ct_lock);
	destroy_workqueue(ct_wq); /* queued ends see ct_unloading and free themselves */
	ct_wq = NULL;
	list_for_each_entry_safe(s, n, &ct_sessions, node) {
		list_del(&s->node);
		ct_session_free(s);
	}
	ct_session_count = 0;
}

/* ---- the decision of one call ------------------------------------------- */

/* Checks transactions ct_txs[0..n) as one transfer. Under ct_lock. Returns
 * the core's transfer action (CT_* below) and the deciding verdict's index. */
enum { CT_PERFORM = 0, CT_REFUSE = 1, CT_IGNORE = 2, CT_SUBSTITUTE = 3, CT_SAFE_STATE = 4 };

/* A record of the call could not be taken: nothing of it acts, it fails
 * with EIO, and the devices go to their safe state -- once per run of lost
 * records, since nothing acts until records are taken again. Under ct_lock. */
static bool ct_failing_closed; /* under ct_lock: the safe state was driven for the lost run */

static u8 ct_fail_unrecorded(struct ct_policy *p, u32 *decider)
{
	contego_abort_transfer(p->checker, CONTEGO_REJECT);
	ct_stats.audit_refused++;
	ct_stats.refused++;
	ct_verdicts[0].decision = CONTEGO_REJECT;
	ct_verdicts[0].reply_errno = EIO;
	*decider = 0;
	if (!ct_failing_closed) {
		ct_failing_closed = true;
		pr_warn_ratelimited("contego: an audit record could not be taken (%s): failing closed, devices to their safe state\n",
				    ct_reader ? "the ring is full" : "no audit reader");
		ct_drive_safe_states(p, CONTEGO_KMOD_SAFE_UNRECORDED);
	}
	return CT_REFUSE;
}

/* Whether the call writes: its first `checked` transactions include a write. */
static bool ct_call_writes(u32 checked)
{
	u32 i;

	for (i = 0; i < checked; i++)
		if (ct_txs[i].kind == CONTEGO_TX_WRITE)
			return true;
	return false;
}

/* A call of `task` refused for the task's `sessions`: an audit record
 * naming the task and the process (not acting: it may be lost to the gap). */
static void ct_record_session_refused(struct ct_policy *p, u16 task)
{
	struct contego_kmod_record r;

	ct_record_start(&r, CONTEGO_KMOD_REC_SESSION_REFUSED, true);
	r.task = task;
	r.count = task < CONTEGO_KMOD_MAX_TASKS ? p->sessions[task] : 1;
	ct_push(&r, false);
	pr_info_ratelimited("contego: task %u: pid %u uid %u refused (EACCES): the task has its %u live session(s)\n",
			    task, r.pid, r.uid, r.count);
}

/* A call of `task` refused (EAGAIN) for want of a session: max_sessions are
 * open, or no memory for one more. Audited as the holds are, at most once a
 * second per task: how many calls were so refused since the last record
 * (not acting: it may be lost to the gap). Under ct_lock. */
static void ct_record_sessions_full(struct ct_policy *p, u16 task, u64 now)
{
	struct contego_kmod_record r;

	if (task >= CONTEGO_KMOD_MAX_TASKS)
		return;
	p->full_unreported[task]++;
	if (p->full_reported_us[task] != 0 && now - p->full_reported_us[task] < 1000000)
		return;
	ct_record_start(&r, CONTEGO_KMOD_REC_SESSIONS_FULL, true);
	r.task = task;
	r.count = p->full_unreported[task];
	r.field_count = 2;
	r.fields[0] = (s32)min_t(u32, ct_session_count, S32_MAX);
	r.fields[1] = (s32)min_t(u32, max_sessions, S32_MAX);
	ct_push(&r, false);
	p->full_unreported[task] = 0;
	p->full_reported_us[task] = now;
}

/* ---- the over-budget hold (docs/kernel-client.md "Budget") --------------- */

/* The monitor's hold_if_over_budget: each task's transfers that write are
 * counted per job on its period grid; past budget_factor x its actuations,
 * the transfer is charged to the next job and waits for that job's release
 * before it is checked. A transfer charged to a later job than the current
 * one (another thread of the task was held before it) waits for that
 * job's release too. Under ct_lock. Returns when the caller may go on: 0
 * now, else the release (CLOCK_MONOTONIC, us) to sleep until. */
static u64 ct_charge(struct ct_policy *p, u16 task, u64 now)
{
	u32 period, job;
	u64 budget;

	if (p->budget_factor == 0 || task >= CONTEGO_KMOD_MAX_TASKS || (p->complain >> task) & 1)
		return 0; /* a complaining task is observed as it runs, never held */
	period = contego_task_period_us(p->checker, task);
	budget = (u64)p->budget_factor * p->actuations[task];
	if (period == 0 || budget == 0)
		return 0;
	job = ct_job(p, task, now);
	if (job > p->budget_job[task]) { /* a new release: a fresh budget */
		p->budget_job[task] = job;
		p->budget_used[task] = 0;
	}
	if (++p->budget_used[task] > budget) {
		p->budget_job[task]++;
		p->budget_used[task] = 1;
	}
	if (p->budget_job[task] <= job)
		return 0;
	ct_stats.holds++;
	p->holds_unreported[task]++;
	if (p->hold_reported_us[task] == 0 || now - p->hold_reported_us[task] >= 1000000) {
		struct contego_kmod_record r;

		ct_record_start(&r, CONTEGO_KMOD_REC_HOLD, true);
		r.task = task;
		r.job = job;
		r.count = p->holds_unreported[task];
		r.field_count = 1;
		r.fields[0] = (s32)min_t(u64, budget, S32_MAX);
		ct_push(&r, false); /* acts nothing: may be lost to the gap */
		p->holds_unreported[task] = 0;
		p->hold_reported_us[task] = now;
	}
	if (!(p->hold_told & (1u << task))) {
		p->hold_told |= 1u << task;
		pr_info("contego: task %u: more than %llu transfers in one job (budget_factor x actuations); further ones wait for the next release\n",
			task, budget);
	}
	return p->phase_us[task] + (u64)(p->budget_job[task] - 1) * period;
}

/* Sleeps until `until_us` on CLOCK_MONOTONIC; -ERESTARTSYS when a signal
 * comes first. */
static int ct_sleep_until(u64 until_us)
{
	ktime_t t = ns_to_ktime(until_us * NSEC_PER_USEC);

	while (ktime_before(ktime_get(), t)) {
		if (signal_pending(current))
			return -ERESTARTSYS;
		set_current_state(TASK_INTERRUPTIBLE);
		schedule_hrtimeout_range(&t, 20 * NSEC_PER_USEC, HRTIMER_MODE_ABS);
	}
	return 0;
}

/* The start of a call, under ct_lock: the caller's task (into *task), and,
 * for a call that writes, the over-budget hold, with ct_lock dropped while
 * it sleeps. 0: go on; 1: go on, but ct_lock was dropped (the call's
 * scratch in ct_txs must be made again); -ERESTARTSYS: a signal cut the
 * hold short, the call does nothing (its charge is given back; restarted,
 * it is charged and held again). A process refused for its task's
 * `sessions` is not charged: it spends nothing of the task's budget. */
static int ct_enter(bool writes, u16 *task)
{
	struct ct_policy *p;
	u64 charged_gen = 0, until;
	u32 charged_job = 0;
	int slept = 0, ret;

	for (;;) {
		p = ct_policy;
		*task = p ? ct_task_of_current(p) : CONTEGO_NONE;
		if (!writes || !p || *task == CONTEGO_NONE || p->gen == charged_gen ||
		    (!ct_session_find(p, *task) && !ct_session_room(p, *task)))
			return slept;
		until = ct_charge(p, *task, div_u64(ktime_get_ns(), 1000));
		if (until == 0)
			return slept;
		charged_gen = p->gen;
		charged_job = p->budget_job[*task];
		mutex_unlock(&ct_lock);
		ret = ct_sleep_until(until);
		mutex_lock(&ct_lock);
		slept = 1;
		if (ret) {
			p = ct_policy; /* the one charged, unless another was loaded meanwhile */
			if (p && p->gen == charged_gen && p->budget_job[*task] == charged_job &&
			    p->budget_used[*task] > 0)
				p->budget_used[*task]--;
			return ret;
		}
	}
}

/* Every write of the call emits the bytes the program sent, at its address. */
static void ct_act_as_sent(u32 n)
{
	u32 i;

	for (i = 0; i < n; i++) {
		contego_verdict *v = &ct_verdicts[i];
		u32 len = min_t(u32, ct_txs[i].len, CONTEGO_MAX_EMIT_BYTES);

		v->decision = CONTEGO_ALLOW;
		v->reply_errno = 0;
		v->addr = ct_txs[i].addr;
		v->emit_count = 0;
		if (ct_txs[i].kind != CONTEGO_TX_WRITE)
			continue;
		v->emit_count = 1;
		v->emit_len[0] = len;
		v->emit_bytes_used = len;
		memcpy(v->emit_bytes, ct_txs[i].bytes, len);
	}
}

/* Decides the call of `task` (ct_enter's) in ct_txs[0..n). Under ct_lock. */
static u8 ct_decide(struct ct_file *cf, u16 task, u32 n, u32 *decider)
{
	struct ct_policy *p = ct_policy;
	struct ct_session *fresh = NULL;
	u8 result;
	contego_transaction tx;
	u32 checked = 0, i, job;
	u8 action;
	u64 now = div_u64(ktime_get_ns(), 1000);

	*decider = 0;
	if (!p) {
		/* No verified image: deny, as the core's kNotLoaded would. */
		ct_verdicts[0].decision = CONTEGO_REJECT;
		ct_verdicts[0].reply_errno = EPERM;
		ct_stats.refused++;
		return CT_REFUSE;
	}
	if (task != CONTEGO_NONE && ct_call_writes(n) && !ct_session_find(p, task)) {
		if (!ct_session_room(p, task)) {
			/* The task has its `sessions` live: as the monitor refuses
			 * a further hello, the call is refused before the core
			 * sees it, and audited. */
			ct_verdicts[0].decision = CONTEGO_REJECT;
			ct_verdicts[0].reply_errno = EACCES;
			ct_stats.sessions_limited++;
			ct_stats.refused++;
			ct_record_session_refused(p, task);
			return CT_REFUSE;
		}
		fresh = ct_session_prepare(p, task);
		if (!fresh) {
			/* No session, no safe state at its end: the call does not act. */
			ct_verdicts[0].decision = CONTEGO_REJECT;
			ct_verdicts[0].reply_errno = EAGAIN;
			ct_stats.sessions_refused++;
			ct_stats.refused++;
			ct_record_sessions_full(p, task, now);
			pr_warn_ratelimited("contego: %u sessions open: a call of task %u refused (EAGAIN)\n",
					    ct_session_count, task);
			return CT_REFUSE;
		}
	}
	job = ct_job(p, task, now);
	ct_complain_now = task < 32 && ((p->complain >> task) & 1);
	contego_begin_transfer(p->checker);
	for (i = 0; i < n; i++) {
		contego_verdict *v = &ct_verdicts[i];

		memset(&tx, 0, sizeof(tx));
		tx.task = task;
		tx.bus = cf->bus;
		tx.kind = ct_txs[i].kind;
		tx.addr = ct_txs[i].addr;
		tx.ten_bit = ct_txs[i].ten;
		tx.job = job;
		tx.len = ct_txs[i].len;
		tx.bytes = ct_txs[i].bytes;
		tx.now_us = now;
		v->decision = CONTEGO_REJECT; /* fail closed if the core leaves it */
		v->reply_errno = EPERM;
		v->emit_count = 0;
		ct_audit_lost = false;
		contego_check(p->checker, &tx, v);
		ct_stats.checks++;
		checked = i + 1;
		if (ct_audit_lost) {
			result = ct_fail_unrecorded(p, decider);
			goto out;
		}
		if (trace)
			pr_info("contego: task %u job %u bus %u addr 0x%02x kind %u len %u: %s (%s) emits %u\n",
				task, job, tx.bus, tx.addr, tx.kind, tx.len,
				contego_decision_name(v->decision), contego_reason_name(v->reason),
				v->emit_count);
		if (v->decision == CONTEGO_REJECT)
			break;
	}
	ct_failing_closed = false; /* every record of this call was taken */
	action = contego_combine_transfer(ct_verdicts, checked, decider);
	if (action == CT_PERFORM || action == CT_SUBSTITUTE) {
		contego_commit_transfer(p->checker);
	} else {
		contego_abort_transfer(p->checker, action == CT_IGNORE ? CONTEGO_IGNORE :
						   action == CT_REFUSE ? CONTEGO_REJECT :
									 CONTEGO_FAILSAFE);
	}
	if (ct_complain_now && action != CT_PERFORM) {
		/* Complain mode: recorded as the policy decides, acted as sent. The
		 * model was undone as for a drop (the monitor's act_as_sent_locked). */
		ct_act_as_sent(n);
		action = CT_PERFORM;
	}
	ct_complain_now = false;
	switch (action) {
	case CT_PERFORM:
		ct_stats.performed++;
		break;
	case CT_IGNORE:
		ct_stats.ignored++;
		break;
	case CT_SUBSTITUTE:
	case CT_SAFE_STATE:
		ct_stats.failsafe++;
		break;
	default:
		ct_stats.refused++;
		break;
	}
	if (action == CT_SAFE_STATE) {
		/* Several messages, one fail-safe: the device's declared safe state
		 * instead of any of them (as the monitor's drive_transfer_safe_states). */
		for (i = 0; i < checked; i++)
			if (ct_verdicts[i].decision == CONTEGO_FAILSAFE)
				ct_drive_safe_state(p, ct_verdicts[i].device, CONTEGO_KMOD_SAFE_TRANSFER);
	}
	if (action == CT_IGNORE && task < CONTEGO_KMOD_MAX_TASKS && p->ignore_errno[task]) {
		/* The policy's `ignore_errno`: nothing acted, and the call says so. */
		ct_verdicts[*decider].reply_errno = p->ignore_errno[task];
		action = CT_REFUSE;
	}
	result = action;
out:
	/* A session begins with the first call that acts as the task: a write
	 * the core allowed or substituted (docs/kernel-client.md "Sessions"). */
	if (fresh && (result == CT_PERFORM || result == CT_SUBSTITUTE) && ct_call_writes(checked))
		ct_session_open(fresh);
	else if (fresh)
		ct_session_free(fresh);
	return result;
}

static int ct_refusal(u32 decider)
{
	u8 e = ct_verdicts[decider].reply_errno;

	return -(e ? e : EPERM);
}

/* ---- write() and read() -------------------------------------------------- */

static ssize_t ct_write(struct file *file, const char __user *buf, size_t count, loff_t *off)
{
	struct ct_file *cf = file->private_data;
	u32 decider;
	u8 *tmp, action;
	u16 task;
	int ret;

	if (count > CT_MAX_LEN)
		count = CT_MAX_LEN;
	tmp = memdup_user(buf, count);
	if (IS_ERR(tmp))
		return PTR_ERR(tmp);
	mutex_lock(&ct_lock);
	ret = ct_enter(true, &task);
	if (ret < 0) {
		mutex_unlock(&ct_lock);
		kfree(tmp);
		return ret;
	}
	ct_txs[0] = (struct ct_tx){ .kind = CONTEGO_TX_WRITE, .addr = cf->addr,
				   .ten = !!(cf->flags & I2C_M_TEN), .len = count, .bytes = tmp };
	action = ct_decide(cf, task, 1, &decider);
	if (action == CT_PERFORM || action == CT_SUBSTITUTE)
		ret = ct_perform_emits(cf->adap, &ct_verdicts[0], cf->flags);
	else if (action == CT_REFUSE)
		ret = ct_refusal(decider);
	else
		ret = 0;
	mutex_unlock(&ct_lock);
	kfree(tmp);
	return ret < 0 ? ret : count;
}

static ssize_t ct_read(struct file *file, char __user *buf, size_t count, loff_t *off)
{
	struct ct_file *cf = file->private_data;
	u32 funcs = i2c_get_functionality(cf->adap);
	u32 decider;
	u8 *tmp, action;
	u16 task;
	int ret;

	if (count > CT_MAX_LEN)
		count = CT_MAX_LEN;
	if (!(funcs & I2C_FUNC_I2C) && !(count == 1 && (funcs & I2C_FUNC_SMBUS_READ_BYTE)))
		return -EOPNOTSUPP;
	tmp = kzalloc(count ? count : 1, GFP_KERNEL);
	if (!tmp)
		return -ENOMEM;
	mutex_lock(&ct_lock);
	ct_enter(false, &task); /* a read is never held */
	ct_txs[0] = (struct ct_tx){ .kind = CONTEGO_TX_READ, .addr = cf->addr,
				   .ten = !!(cf->flags & I2C_M_TEN) };
	action = ct_decide(cf, task, 1, &decider);
	if (action == CT_PERFORM) {
		if (funcs & I2C_FUNC_I2C) {
			struct i2c_msg m = { .addr = cf->addr, .flags = I2C_M_RD | (cf->flags & I2C_M_TEN),
					     .len = count, .buf = tmp };

			ret = i2c_transfer(cf->adap, &m, 1);
			ret = ret == 1 ? 0 : (ret < 0 ? ret : -EIO);
		} else {
			union i2c_smbus_data d;

			ret = i2c_smbus_xfer(cf->adap, cf->addr, cf->flags & I2C_CLIENT_PEC,
					     I2C_SMBUS_READ, 0, I2C_SMBUS_BYTE, &d);
			if (ret >= 0) {
				tmp[0] = d.byte;
				ret = 0;
			}
		}
	} else if (action == CT_REFUSE) {
		ret = ct_refusal(decider);
	} else {
		ret = 0; /* ignored: it succeeds and reads nothing (zeros) */
	}
	mutex_unlock(&ct_lock);
	if (ret == 0 && copy_to_user(buf, tmp, count))
		ret = -EFAULT;
	kfree(tmp);
	return ret < 0 ? ret : count;
}

/* ---- I2C_RDWR ------------------------------------------------------------ */

/* The gate's normalisation (src/gate/transfer.cc, to_transactions): a
 * one-byte write followed by a read of the same address is that read's
 * register pointer (except at the general-call address 0). */
static u32 ct_plan_msgs(const struct i2c_msg *m, u32 n)
{
	u32 i, t = 0;

	for (i = 0; i < n; i++, t++) {
		struct ct_tx *tx = &ct_txs[t];

		*tx = (struct ct_tx){ .addr = m[i].addr, .ten = !!(m[i].flags & I2C_M_TEN),
				      .first_msg = i, .msg_count = 1 };
		if (m[i].flags & I2C_M_RD) {
			tx->kind = CONTEGO_TX_READ;
		} else if (m[i].len == 1 && i + 1 < n && (m[i + 1].flags & I2C_M_RD) &&
			   m[i + 1].addr == m[i].addr &&
			   (m[i + 1].flags & I2C_M_TEN) == (m[i].flags & I2C_M_TEN) && m[i].addr != 0) {
			tx->kind = CONTEGO_TX_READ;
			tx->bytes = m[i].buf;
			tx->len = 1;
			tx->msg_count = 2;
			i++;
		} else {
			tx->kind = CONTEGO_TX_WRITE;
			tx->bytes = m[i].buf;
			tx->len = m[i].len;
		}
	}
	return t;
}

/*
 * A read of an I2C_RDWR call on an SMBus-only adapter (i2c-stub, many SoC
 * controllers), as the monitor sends it (src/bus/smbus_plan.h): a one-byte
 * register pointer and a read become read byte data (1 byte), read word data
 * (2) or an I2C block read (up to 32); a lone one-byte read is receive byte.
 * `check_only`: whether the adapter has the form, nothing sent. 0 or -errno.
 */
static int ct_smbus_read(struct i2c_adapter *adap, struct i2c_msg *m, const struct ct_tx *tx,
			 bool check_only)
{
	u32 funcs = i2c_get_functionality(adap);
	struct i2c_msg *rd = &m[tx->first_msg + tx->msg_count - 1];
	union i2c_smbus_data data;
	int size, r;

	if (rd->flags & I2C_M_TEN)
		return -EOPNOTSUPP;
	if (tx->msg_count == 1)
		size = rd->len == 1 && (funcs & I2C_FUNC_SMBUS_READ_BYTE) ? I2C_SMBUS_BYTE : -1;
	else if (rd->len == 1 && (funcs & I2C_FUNC_SMBUS_READ_BYTE_DATA))
		size = I2C_SMBUS_BYTE_DATA;
	else if (rd->len == 2 && (funcs & I2C_FUNC_SMBUS_READ_WORD_DATA))
		size = I2C_SMBUS_WORD_DATA;
	else if (rd->len >= 1 && rd->len <= I2C_SMBUS_BLOCK_MAX &&
		 (funcs & I2C_FUNC_SMBUS_READ_I2C_BLOCK))
		size = I2C_SMBUS_I2C_BLOCK_DATA;
	else
		size = -1;
	if (size < 0)
		return -EOPNOTSUPP;
	if (check_only)
		return 0;
	data.block[0] = rd->len;
	r = i2c_smbus_xfer(adap, rd->addr, 0, I2C_SMBUS_READ,
			   tx->msg_count == 2 ? tx->bytes[0] : 0, size, &data);
	if (r < 0)
		return r;
	if (size == I2C_SMBUS_WORD_DATA) {
		rd->buf[0] = data.word & 0xff;
		rd->buf[1] = data.word >> 8;
	} else if (size == I2C_SMBUS_I2C_BLOCK_DATA) {
		memcpy(rd->buf, &data.block[1], rd->len);
	} else {
		rd->buf[0] = data.byte;
	}
	return 0;
}

/* The call's reads and writes all have a form on this adapter. */
static bool ct_expressible(struct i2c_adapter *adap, struct i2c_msg *m, u32 ntx)
{
	u32 funcs = i2c_get_functionality(adap), i;

	if (funcs & I2C_FUNC_I2C)
		return true;
	for (i = 0; i < ntx; i++) {
		const struct ct_tx *tx = &ct_txs[i];

		if (tx->kind == CONTEGO_TX_READ) {
			if (ct_smbus_read(adap, m, tx, true) < 0)
				return false;
		} else if (tx->ten || tx->len > 1 + I2C_SMBUS_BLOCK_MAX ||
			   (tx->len > 3 && !(funcs & I2C_FUNC_SMBUS_WRITE_I2C_BLOCK))) {
			return false;
		}
	}
	return true;
}

static long ct_ioctl_rdwr(struct ct_file *cf, struct i2c_msg *msgs, u32 nmsgs,
			  u8 __user **user_bufs)
{
	u32 ntx, decider, i;
	u8 action;
	u16 task;
	long ret = 0;
	int r;

	mutex_lock(&ct_lock);
	ntx = ct_plan_msgs(msgs, nmsgs);
	if (!ct_expressible(cf->adap, msgs, ntx)) {
		/* No form on this adapter: refused before the core decides, as
		 * i2c_transfer refuses it on an SMBus-only adapter. */
		mutex_unlock(&ct_lock);
		return -EOPNOTSUPP;
	}
	r = ct_enter(ct_call_writes(ntx), &task);
	if (r < 0) {
		mutex_unlock(&ct_lock);
		return r;
	}
	if (r > 0) /* held: ct_txs served other calls meanwhile */
		ntx = ct_plan_msgs(msgs, nmsgs);
	action = ct_decide(cf, task, ntx, &decider);
	if (action == CT_REFUSE) {
		ret = ct_refusal(decider);
	} else if (action == CT_PERFORM || action == CT_SUBSTITUTE) {
		/* In message order, only what the core allowed or substituted. */
		for (i = 0; i < ntx && ret == 0; i++) {
			struct ct_tx *tx = &ct_txs[i];

			if (tx->kind == CONTEGO_TX_WRITE) {
				ret = ct_perform_emits(cf->adap, &ct_verdicts[i],
						       tx->ten ? I2C_M_TEN : 0);
			} else if (!(i2c_get_functionality(cf->adap) & I2C_FUNC_I2C)) {
				ret = ct_smbus_read(cf->adap, msgs, tx, false);
			} else {
				r = i2c_transfer(cf->adap, &msgs[tx->first_msg], tx->msg_count);
				ret = r == tx->msg_count ? 0 : (r < 0 ? r : -EIO);
			}
		}
	} else {
		for (i = 0; i < nmsgs; i++) /* ignored: reads read zeros */
			if (msgs[i].flags & I2C_M_RD)
				memset(msgs[i].buf, 0, msgs[i].len);
	}
	mutex_unlock(&ct_lock);
	if (ret < 0)
		return ret;
	for (i = 0; i < nmsgs; i++) {
		if ((msgs[i].flags & I2C_M_RD) &&
		    copy_to_user(user_bufs[i], msgs[i].buf, msgs[i].len))
			return -EFAULT;
	}
	return nmsgs;
}

/* I2C_RDWR on messages copied in (their buffers still the caller's): the
 * native and the compat call both end here, as in i2c-dev. The caller frees
 * msgs. */
static long ct_rdwr_msgs(struct ct_file *cf, struct i2c_msg *msgs, u32 nmsgs)
{
	u8 __user **user_bufs;
	long ret;
	u32 i;

	user_bufs = kcalloc(nmsgs, sizeof(*user_bufs), GFP_KERNEL);
	if (!user_bufs)
		return -ENOMEM;
	ret = 0;
	for (i = 0; i < nmsgs; i++) {
		user_bufs[i] = (u8 __user *)msgs[i].buf;
		/* The shared allow-list (contego/i2c_msg_flags.h): a protocol-
		 * mangling flag would let a checked read act as a write. */
		if (msgs[i].len > CT_MAX_LEN || contego_i2c_refused_flags(msgs[i].flags)) {
			ret = -EINVAL;
			break;
		}
		/* The one copy everything below checks and sends. */
		msgs[i].buf = memdup_user(user_bufs[i], msgs[i].len);
		if (IS_ERR(msgs[i].buf)) {
			ret = PTR_ERR(msgs[i].buf);
			break;
		}
		if ((msgs[i].flags & I2C_M_RECV_LEN) &&
		    (!(msgs[i].flags & I2C_M_RD) || msgs[i].len < 1 || msgs[i].buf[0] < 1 ||
		     msgs[i].len < msgs[i].buf[0] + I2C_SMBUS_BLOCK_MAX)) {
			i++;
			ret = -EINVAL;
			break;
		}
		if (msgs[i].flags & I2C_M_RECV_LEN)
			msgs[i].len = msgs[i].buf[0];
	}
	if (ret == 0)
		ret = ct_ioctl_rdwr(cf, msgs, nmsgs, user_bufs);
	while (i-- > 0)
		if (!IS_ERR_OR_NULL(msgs[i].buf))
			kfree(msgs[i].buf);
	kfree(user_bufs);
	return ret;
}

static long ct_rdwr(struct ct_file *cf, unsigned long arg)
{
	struct i2c_rdwr_ioctl_data rd;
	struct i2c_msg *msgs;
	long ret;

	if (copy_from_user(&rd, (void __user *)arg, sizeof(rd)))
		return -EFAULT;
	if (!rd.msgs || rd.nmsgs == 0 || rd.nmsgs > CT_MAX_MSGS)
		return -EINVAL;
	msgs = memdup_user(rd.msgs, rd.nmsgs * sizeof(*msgs));
	if (IS_ERR(msgs))
		return PTR_ERR(msgs);
	ret = ct_rdwr_msgs(cf, msgs, rd.nmsgs);
	kfree(msgs);
	return ret;
}

/* ---- I2C_SMBUS ----------------------------------------------------------- */

/* I2C_SMBUS with its arguments copied in (native or compat). */
static long ct_smbus(struct ct_file *cf, struct i2c_smbus_ioctl_data a)
{
	union i2c_smbus_data data;
	u8 wire[2 + I2C_SMBUS_BLOCK_MAX + 1]; /* command, count, data: the write's bytes */
	u8 pointer;
	u32 datasize = 0, n, decider;
	bool read, proc;
	u8 action;
	u16 task;
	long ret;

	if (a.size != I2C_SMBUS_BYTE && a.size != I2C_SMBUS_QUICK && a.size != I2C_SMBUS_BYTE_DATA &&
	    a.size != I2C_SMBUS_WORD_DATA && a.size != I2C_SMBUS_PROC_CALL &&
	    a.size != I2C_SMBUS_BLOCK_DATA && a.size != I2C_SMBUS_I2C_BLOCK_BROKEN &&
	    a.size != I2C_SMBUS_I2C_BLOCK_DATA && a.size != I2C_SMBUS_BLOCK_PROC_CALL)
		return -EINVAL;
	if (a.read_write != I2C_SMBUS_READ && a.read_write != I2C_SMBUS_WRITE)
		return -EINVAL;
	memset(&data, 0, sizeof(data));
	if (!(a.size == I2C_SMBUS_QUICK || (a.size == I2C_SMBUS_BYTE && a.read_write == I2C_SMBUS_WRITE))) {
		if (!a.data)
			return -EINVAL;
		if (a.size == I2C_SMBUS_BYTE_DATA || a.size == I2C_SMBUS_BYTE)
			datasize = sizeof(data.byte);
		else if (a.size == I2C_SMBUS_WORD_DATA || a.size == I2C_SMBUS_PROC_CALL)
			datasize = sizeof(data.word);
		else
			datasize = sizeof(data.block);
		if ((a.size == I2C_SMBUS_PROC_CALL || a.size == I2C_SMBUS_BLOCK_PROC_CALL ||
		     a.size == I2C_SMBUS_I2C_BLOCK_DATA || a.read_write == I2C_SMBUS_WRITE) &&
		    copy_from_user(&data, a.data, datasize))
			return -EFAULT;
		if (a.size == I2C_SMBUS_I2C_BLOCK_BROKEN) {
			a.size = I2C_SMBUS_I2C_BLOCK_DATA;
			if (a.read_write == I2C_SMBUS_READ)
				data.block[0] = I2C_SMBUS_BLOCK_MAX;
		}
	}
	proc = a.size == I2C_SMBUS_PROC_CALL || a.size == I2C_SMBUS_BLOCK_PROC_CALL;
	read = a.read_write == I2C_SMBUS_READ && !proc;

	if ((a.size == I2C_SMBUS_BLOCK_DATA || a.size == I2C_SMBUS_BLOCK_PROC_CALL ||
	     a.size == I2C_SMBUS_I2C_BLOCK_DATA) && !read &&
	    (data.block[0] < 1 || data.block[0] > I2C_SMBUS_BLOCK_MAX))
		return -EINVAL;

	mutex_lock(&ct_lock);
	/* Held before ct_txs is made: an SMBus call writes unless it is a
	 * quick command or a read (a process call writes). */
	ret = ct_enter(a.size != I2C_SMBUS_QUICK && !read, &task);
	if (ret < 0) {
		mutex_unlock(&ct_lock);
		return ret;
	}
	/* ct_txs is shared scratch, used under ct_lock only. The transactions
	 * this call puts on the wire (smbus_plan.h's table, backwards): */
	n = 0;
	pointer = a.command;
	if (a.size == I2C_SMBUS_QUICK) {
		ct_txs[n++] = (struct ct_tx){ .kind = CONTEGO_TX_QUICK, .addr = cf->addr };
	} else if (read) {
		ct_txs[n++] = (struct ct_tx){ .kind = CONTEGO_TX_READ, .addr = cf->addr,
					     .len = a.size == I2C_SMBUS_BYTE ? 0 : 1,
					     .bytes = &pointer };
	} else {
		u32 len = 1;

		wire[0] = a.command;
		switch (a.size) {
		case I2C_SMBUS_BYTE:
			break;
		case I2C_SMBUS_BYTE_DATA:
			wire[len++] = data.byte;
			break;
		case I2C_SMBUS_WORD_DATA:
		case I2C_SMBUS_PROC_CALL:
			wire[len++] = data.word & 0xff;
			wire[len++] = data.word >> 8;
			break;
		case I2C_SMBUS_BLOCK_DATA:
		case I2C_SMBUS_BLOCK_PROC_CALL:
			memcpy(&wire[len], data.block, 1 + data.block[0]);
			len += 1 + data.block[0];
			break;
		case I2C_SMBUS_I2C_BLOCK_DATA:
			memcpy(&wire[len], &data.block[1], data.block[0]);
			len += data.block[0];
			break;
		}
		ct_txs[n++] = (struct ct_tx){ .kind = CONTEGO_TX_WRITE, .addr = cf->addr,
					     .len = len, .bytes = wire };
		if (proc) /* then a read without pointer (the write is longer than one byte) */
			ct_txs[n++] = (struct ct_tx){ .kind = CONTEGO_TX_READ, .addr = cf->addr };
	}

	action = ct_decide(cf, task, n, &decider);
	if (action == CT_REFUSE) {
		ret = ct_refusal(decider);
	} else if (action == CT_IGNORE || action == CT_SAFE_STATE) {
		ret = 0;
		memset(&data, 0, sizeof(data));
	} else if (a.size == I2C_SMBUS_QUICK || read ||
		   ct_emits_are(&ct_verdicts[0], wire, ct_txs[0].len, cf->addr)) {
		/* Exactly what was asked: the call itself, from our copy. */
		ret = i2c_smbus_xfer(cf->adap, cf->addr, cf->flags, a.read_write, a.command,
				     a.size, (a.size == I2C_SMBUS_QUICK ||
					      (a.size == I2C_SMBUS_BYTE && !read)) ? NULL : &data);
	} else if (proc) {
		ret = -EOPNOTSUPP; /* a substituted process call has no SMBus form */
	} else {
		ret = ct_perform_emits(cf->adap, &ct_verdicts[0], cf->flags);
	}
	mutex_unlock(&ct_lock);
	if (ret < 0)
		return ret;
	if ((read || proc) && datasize && copy_to_user(a.data, &data, datasize))
		return -EFAULT;
	return 0;
}

/* ---- the node ------------------------------------------------------------ */

static int ct_check_addr_busy(struct device *dev, void *addrp)
{
	struct i2c_client *client = i2c_verify_client(dev);

	if (!client || client->addr != *(unsigned int *)addrp)
		return 0;
	return dev->driver ? -EBUSY : 0;
}

static long ct_ioctl(struct file *file, unsigned int cmd, unsigned long arg)
{
	struct ct_file *cf = file->private_data;
	unsigned int addr;

	switch (cmd) {
	case I2C_SLAVE:
	case I2C_SLAVE_FORCE:
		if (arg > 0x3ff || ((cf->flags & I2C_M_TEN) == 0 && arg > 0x7f))
			return -EINVAL;
		addr = arg;
		if (cmd == I2C_SLAVE &&
		    device_for_each_child(&cf->adap->dev, &addr, ct_check_addr_busy))
			return -EBUSY;
		/* No check here: the address is checked with each transaction. */
		cf->addr = arg;
		return 0;
	case I2C_TENBIT:
		if (arg)
			cf->flags |= I2C_M_TEN;
		else
			cf->flags &= ~I2C_M_TEN;
		return 0;
	case I2C_PEC:
		if (arg)
			cf->flags |= I2C_CLIENT_PEC;
		else
			cf->flags &= ~I2C_CLIENT_PEC;
		return 0;
	case I2C_FUNCS:
		return put_user(i2c_get_functionality(cf->adap), (unsigned long __user *)arg);
	case I2C_RDWR:
		return ct_rdwr(cf, arg);
	case I2C_SMBUS: {
		struct i2c_smbus_ioctl_data a;

		if (copy_from_user(&a, (void __user *)arg, sizeof(a)))
			return -EFAULT;
		return ct_smbus(cf, a);
	}
	case I2C_RETRIES:
		if (arg > INT_MAX)
			return -EINVAL;
		cf->adap->retries = arg;
		return 0;
	case I2C_TIMEOUT:
		if (arg > INT_MAX / 10) /* as i2c-dev: arg * 10 must not wrap */
			return -EINVAL;
		cf->adap->timeout = msecs_to_jiffies(arg * 10);
		return 0;
	default:
		return -ENOTTY;
	}
}

#ifdef CONFIG_COMPAT
/* 32-bit programs on a 64-bit kernel (armhf Raspberry Pi OS on its arm64
 * kernel, i386 on amd64): i2c-dev's compat layouts, converted, then the
 * native paths. Scalar requests are the same in both ABIs. */
struct ct_msg32 {
	u16 addr;
	u16 flags;
	u16 len;
	compat_caddr_t buf;
};

struct ct_rdwr32 {
	compat_caddr_t msgs;
	u32 nmsgs;
};

struct ct_smbus32 {
	u8 read_write;
	u8 command;
	u32 size;
	compat_caddr_t data;
};

static long ct_compat_rdwr(struct ct_file *cf, unsigned long arg)
{
	struct ct_msg32 __user *umsgs;
	struct ct_rdwr32 rd;
	struct i2c_msg *msgs;
	long ret = 0;
	u32 i;

	if (copy_from_user(&rd, compat_ptr(arg), sizeof(rd)))
		return -EFAULT;
	if (!rd.msgs || rd.nmsgs == 0 || rd.nmsgs > CT_MAX_MSGS)
		return -EINVAL;
	msgs = kcalloc(rd.nmsgs, sizeof(*msgs), GFP_KERNEL);
	if (!msgs)
		return -ENOMEM;
	umsgs = compat_ptr(rd.msgs);
	for (i = 0; i < rd.nmsgs; i++) {
		struct ct_msg32 m;

		if (copy_from_user(&m, &umsgs[i], sizeof(m))) {
			ret = -EFAULT;
			goto out;
		}
		msgs[i] = (struct i2c_msg){ .addr = m.addr, .flags = m.flags, .len = m.len,
					    .buf = (__force u8 *)compat_ptr(m.buf) };
	}
	ret = ct_rdwr_msgs(cf, msgs, rd.nmsgs);
out:
	kfree(msgs);
	return ret;
}

static long ct_compat_ioctl(struct file *file, unsigned int cmd, unsigned long arg)
{
	struct ct_file *cf = file->private_data;

	switch (cmd) {
	case I2C_FUNCS:
		return put_user(i2c_get_functionality(cf->adap),
				(compat_ulong_t __user *)compat_ptr(arg));
	case I2C_RDWR:
		return ct_compat_rdwr(cf, arg);
	case I2C_SMBUS: {
		struct ct_smbus32 a;

		if (copy_from_user(&a, compat_ptr(arg), sizeof(a)))
			return -EFAULT;
		return ct_smbus(cf, (struct i2c_smbus_ioctl_data){
			.read_write = a.read_write, .command = a.command, .size = a.size,
			.data = compat_ptr(a.data) });
	}
	default:
		return ct_ioctl(file, cmd, arg);
	}
}
#endif

static int ct_open(struct inode *inode, struct file *file)
{
	struct ct_node *node = container_of(inode->i_cdev, struct ct_node, cdev);
	struct ct_file *cf;
	struct i2c_adapter *adap;

	adap = i2c_get_adapter(node->nr);
	if (!adap)
		return -ENODEV;
	cf = kzalloc(sizeof(*cf), GFP_KERNEL);
	if (!cf) {
		i2c_put_adapter(adap);
		return -ENOMEM;
	}
	cf->adap = adap;
	cf->bus = node->bus;
	file->private_data = cf;
	return 0;
}

static int ct_release(struct inode *inode, struct file *file)
{
	struct ct_file *cf = file->private_data;

	i2c_put_adapter(cf->adap);
	kfree(cf);
	file->private_data = NULL;
	return 0;
}

static const struct file_operations ct_node_fops = {
	.owner = THIS_MODULE,
#if LINUX_VERSION_CODE < KERNEL_VERSION(6, 12, 0)
	.llseek = no_llseek, /* 6.12: no .llseek is no seeking */
#endif
	.read = ct_read,
	.write = ct_write,
	.unlocked_ioctl = ct_ioctl,
#ifdef CONFIG_COMPAT
	.compat_ioctl = ct_compat_ioctl,
#endif
	.open = ct_open,
	.release = ct_release,
};

/* ---- /dev/contego: policy load ------------------------------------------ */

static void ct_policy_free(struct ct_policy *p)
{
	if (!p)
		return;
	kvfree(p->mem);
	kvfree(p->image);
	kfree(p);
}

/*
 * A register-map device configured before the load (a vendor library's
 * init, an earlier policy) need not hold its power-on values: the shadow
 * the core keeps of it is read back from the device, every register its
 * commands cover, as the monitor does at start. A device that refuses a
 * read keeps the power-on shadow (a write-only chip). Before the policy is
 * live, so the safe state and the first checks see what the chip holds.
 */
static void ct_seed_shadows(struct ct_policy *p)
{
	u32 d, i, n, count = contego_device_count(p->checker);
	u8 *regs = kmalloc(2 * 256, GFP_KERNEL);
	u8 *values = regs + 256;

	if (!regs)
		return;
	for (d = 0; d < count; d++) {
		contego_device_info info;
		union i2c_smbus_data data;
		struct ct_node *node;
		struct i2c_adapter *adap;
		int ret = -ENODEV;

		n = contego_command_registers(p->checker, d, regs);
		if (n == 0 || !contego_device_info_of(p->checker, d, &info))
			continue;
		node = ct_node_for_bus(info.bus);
		adap = node ? i2c_get_adapter(node->nr) : NULL;
		for (i = 0; adap && i < n; i++) {
			ret = i2c_smbus_xfer(adap, info.addr, info.ten_bit ? I2C_CLIENT_TEN : 0,
					     I2C_SMBUS_READ, regs[i], I2C_SMBUS_BYTE_DATA, &data);
			if (ret < 0)
				break;
			values[i] = data.byte;
		}
		if (adap)
			i2c_put_adapter(adap);
		if (!adap || i < n) {
			pr_warn("contego: device %u (bus %u 0x%02x): register 0x%02x cannot be read (%d); its shadow keeps the power-on values\n",
				d, info.bus, info.addr, i < n ? regs[i] : 0, ret);
			continue;
		}
		for (i = 0; i < n; i++)
			contego_seed_register(p->checker, d, regs[i], values[i]);
		pr_info("contego: device %u (bus %u 0x%02x): shadow read back from the device (%u registers)\n",
			d, info.bus, info.addr, n);
	}
	kfree(regs);
}

/* The header CRC-32 of a policy's image (bytes 12..15): what names it in
 * the audit ring's LOAD records and what a load in place is paired against. */
static u32 ct_image_crc(const struct ct_policy *p)
{
	__le32 crc;

	memcpy(&crc, p->image + 12, sizeof(crc));
	return le32_to_cpu(crc);
}

/* A load in place (CONTEGO_KMOD_RELOAD): the caller's pairs, copied in. */
struct ct_carry {
	u32 running_crc;
	u32 counts[5]; /* tasks, devices, commands, rates, invariants */
	u16 *pairs;
	u32 staged_dropped;
};

/* The new policy `p` takes over `old`'s run-time state for the paired
 * records: the core's model (contego_carry_from checks every pair), the
 * module's own per task (the job grid's phase, the budget's job and use)
 * and per device (the newest sensor sample), and the live sessions, so that
 * a program's end after the reload still drives its actuators to their
 * safe state. A task with live sessions must be paired (as the monitor's
 * reload requires): else -EBUSY. */
static int ct_carry_locked(struct ct_policy *p, const struct ct_policy *old, struct ct_carry *c)
{
	contego_carry_map map;
	struct ct_session *s;
	u32 t, d;

	lockdep_assert_held(&ct_lock);
	if (!old || ct_image_crc(old) != c->running_crc) {
		pr_warn("contego: load in place refused: the image in force (CRC %08x) is not the one the pairs were made against (%08x); the policy in force stays\n",
			old ? ct_image_crc(old) : 0, c->running_crc);
		return -ESTALE;
	}
	map.tasks = c->pairs;
	map.devices = map.tasks + c->counts[0];
	map.commands = map.devices + c->counts[1];
	map.rates = map.commands + c->counts[2];
	map.invariants = map.rates + c->counts[3];
	list_for_each_entry(s, &ct_sessions, node) {
		if (s->gen != old->gen)
			continue;
		for (t = 0; t < c->counts[0] && map.tasks[t] != s->task; t++)
			;
		if (t == c->counts[0] || t != s->task) {
			pr_warn("contego: load in place refused: task %u has a live session (pid %u) and the new policy does not keep it under its name and id; the policy in force stays\n",
				s->task, s->pid);
			return -EBUSY;
		}
	}
	if (!contego_carry_from(p->checker, old->checker, &map, &c->staged_dropped)) {
		pr_warn("contego: load in place refused: the core found a pair that disagrees (another bus, address, profile, task or an id out of range); the policy in force stays\n");
		return -EINVAL;
	}
	/* The core checked every id against the old image's tables. */
	for (t = 0; t < c->counts[0] && t < CONTEGO_KMOD_MAX_TASKS; t++) {
		u16 o = map.tasks[t];

		if (o >= CONTEGO_KMOD_MAX_TASKS)
			continue;
		if (old->phase_set & BIT(o)) {
			p->phase_us[t] = old->phase_us[o];
			p->phase_set |= BIT(t);
		}
		p->budget_job[t] = old->budget_job[o];
		p->budget_used[t] = old->budget_used[o];
	}
	for (d = 0; d < c->counts[1] && d < ARRAY_SIZE(p->samples); d++)
		if (map.devices[d] < ARRAY_SIZE(old->samples))
			p->samples[d] = old->samples[map.devices[d]];
	list_for_each_entry(s, &ct_sessions, node)
		if (s->gen == old->gen)
			s->gen = p->gen; /* the same task id: checked above */
	return 0;
}

static long ct_load(unsigned long arg, struct ct_carry *carry)
{
	struct contego_kmod_load req;
	struct ct_policy *p, *old;
	contego_load_result r;
	size_t size = contego_checker_size();
	long ret = 0;
	u32 i;

	if (copy_from_user(&req, (void __user *)arg, sizeof(req)))
		return -EFAULT;
	if (req.version != CONTEGO_KMOD_LOAD_VERSION) {
		pr_warn("contego: CONTEGO_KMOD_LOAD version %u refused: this module takes version %u (use the contego built with it)\n",
			req.version, CONTEGO_KMOD_LOAD_VERSION);
		req.version = CONTEGO_KMOD_LOAD_VERSION;
		if (copy_to_user((void __user *)arg, &req.version, sizeof(req.version)))
			return -EFAULT;
		return -EPROTO;
	}
	if (req.size == 0 || req.size > CONTEGO_KMOD_MAX_IMAGE || req.nbinds > CONTEGO_KMOD_MAX_BINDS ||
	    req.ntasks > CONTEGO_KMOD_MAX_TASKS)
		return -EINVAL;
	for (i = 0; i < req.ntasks; i++)
		if (req.sessions[i] < 1 || req.sessions[i] > CONTEGO_KMOD_MAX_TASK_SESSIONS)
			return -EINVAL;
	p = kzalloc(sizeof(*p), GFP_KERNEL);
	if (!p)
		return -ENOMEM;
	for (i = 0; i < CONTEGO_KMOD_MAX_TASKS; i++) {
		/* A task the request does not cover: the monitor's default, one session. */
		p->sessions[i] = i < req.ntasks ? req.sessions[i] : 1;
		p->actuations[i] = i < req.ntasks ? req.actuations[i] : 0;
		p->ignore_errno[i] = i < req.ntasks ? req.ignore_errno[i] : 0;
	}
	p->budget_factor = req.budget_factor;
	p->complain = req.complain;
	p->mem = kvzalloc(size + contego_checker_align(), GFP_KERNEL);
	p->image = kvmalloc(req.size, GFP_KERNEL);
	if (!p->mem || !p->image) {
		ret = -ENOMEM;
		goto fail;
	}
	if (copy_from_user(p->image, u64_to_user_ptr(req.image), req.size) ||
	    copy_from_user(p->binds, u64_to_user_ptr(req.binds), req.nbinds * sizeof(p->binds[0]))) {
		ret = -EFAULT;
		goto fail;
	}
	p->nbinds = req.nbinds;
	p->size = req.size;
	for (i = 0; i < p->nbinds; i++) {
		struct contego_kmod_bind *b = &p->binds[i];

		/* Strings terminated here, whatever the caller sent. */
		b->cgroup[sizeof(b->cgroup) - 1] = '\0';
		b->unit[sizeof(b->unit) - 1] = '\0';
		if ((b->cgroup[0] && b->cgroup[0] != '/') || (b->flags & ~CONTEGO_KMOD_BIND_EXE)) {
			ret = -EINVAL;
			goto fail;
		}
	}
	/* kvzalloc is page- or slab-aligned: enough for the checker (checked). */
	p->checker = contego_checker_init(p->mem, size);
	if (!p->checker) {
		ret = -EINVAL;
		goto fail;
	}
	/* The core's verifier, on our copy, before anything uses it. */
	r = contego_load(p->checker, p->image, req.size);
	req.status = r.status;
	req.section = r.section;
	req.index = r.index;
	if (r.status != 0) {
		struct contego_kmod_record rec;

		mutex_lock(&ct_lock);
		ct_stats.refused_loads++;
		ct_record_start(&rec, CONTEGO_KMOD_REC_LOAD_REFUSED, true);
		rec.reason = r.status;
		rec.count = req.size;
		ct_push(&rec, false);
		mutex_unlock(&ct_lock);
		pr_warn("contego: image refused by the verifier: %s (section %u, index %u); the previous policy stays\n",
			contego_load_status_name(r.status), r.section, r.index);
		ret = -EINVAL;
		goto fail;
	}
	/* The per-task limits must be the image's tasks' (each has a period). */
	for (i = 0; i < CONTEGO_KMOD_MAX_TASKS && contego_task_period_us(p->checker, i); i++)
		;
	if (i != req.ntasks) {
		pr_warn("contego: the load's per-task limits cover %u tasks, the image has %u: refused\n",
			req.ntasks, i);
		ret = -EINVAL;
		goto fail;
	}
	/* A binding must name a task of the image: one that does not would
	 * bind its processes to nothing the policy decides about. */
	for (i = 0; i < p->nbinds; i++) {
		if (p->binds[i].task >= req.ntasks) {
			pr_warn("contego: binding %u names task %u, the image has %u tasks: refused\n",
				i, p->binds[i].task, req.ntasks);
			ret = -EINVAL;
			goto fail;
		}
	}
	{
		/* The host, copied by the facade: samples for p, records to the ring. */
		const contego_host host = { .context = p, .read_sample = ct_read_sample,
					    .audit = ct_audit };

		contego_set_host(p->checker, &host);
	}
	if (carry) {
		contego_record_counts n;

		contego_record_counts_of(p->checker, &n);
		if (n.tasks != carry->counts[0] || n.devices != carry->counts[1] ||
		    n.commands != carry->counts[2] || n.rates != carry->counts[3] ||
		    n.invariants != carry->counts[4]) {
			pr_warn("contego: load in place refused: its pairs do not cover the new image's records; the policy in force stays\n");
			ret = -EINVAL;
			goto fail;
		}
	}
	ct_seed_shadows(p);
	mutex_lock(&ct_lock);
	old = ct_policy;
	p->gen = ++ct_gen;
	if (carry) {
		ret = ct_carry_locked(p, old, carry);
		if (ret) {
			mutex_unlock(&ct_lock);
			goto fail;
		}
	}
	ct_policy = p;
	ct_stats.loads++;
	ct_stats.loaded = 1;
	{
		struct contego_kmod_record rec;

		ct_record_start(&rec, CONTEGO_KMOD_REC_LOAD, true);
		rec.count = req.size;
		/* Which image: its header's CRC-32, so that a reader names the
		 * records that follow from this image alone; in place, the one
		 * it replaced too. */
		rec.fields[0] = (s32)ct_image_crc(p);
		rec.field_count = 1;
		if (carry) {
			rec.fields[1] = (s32)ct_image_crc(old);
			rec.field_count = 2;
		}
		ct_push(&rec, true);
	}
	/* In place, the actuators keep what the running policy let them do. */
	req.devices = carry ? 0 : ct_drive_safe_states(p, CONTEGO_KMOD_SAFE_LOAD);
	mutex_unlock(&ct_lock);
	ct_policy_free(old);
	if (carry)
		pr_info("contego: policy loaded in place (%u bytes, %u bindings, state carried over, %u staged writes dropped, no safe state driven, budget factor %u)\n",
			req.size, req.nbinds, carry->staged_dropped, req.budget_factor);
	else
		pr_info("contego: policy loaded (%u bytes, %u bindings, %u devices in their safe state, budget factor %u)\n",
			req.size, req.nbinds, req.devices, req.budget_factor);
	if (copy_to_user((void __user *)arg, &req, sizeof(req)))
		return -EFAULT;
	return 0;
fail:
	ct_policy_free(p);
	if (req.status != 0 && copy_to_user((void __user *)arg, &req, sizeof(req)))
		return -EFAULT;
	return ret;
}

/* CONTEGO_KMOD_RELOAD: the pairs copied in, then a load that carries. */
static long ct_reload(unsigned long arg)
{
	struct contego_kmod_reload req;
	struct ct_carry carry;
	size_t n = 0;
	long ret;
	int i;

	if (copy_from_user(&req, (void __user *)arg, sizeof(req)))
		return -EFAULT;
	for (i = 0; i < 5; i++) {
		if (req.counts[i] > CONTEGO_KMOD_MAX_IMAGE / 8)
			return -EINVAL;
		n += req.counts[i];
	}
	carry.running_crc = req.running_crc;
	memcpy(carry.counts, req.counts, sizeof(carry.counts));
	carry.staged_dropped = 0;
	carry.pairs = kvmalloc_array(n ? n : 1, sizeof(u16), GFP_KERNEL);
	if (!carry.pairs)
		return -ENOMEM;
	if (copy_from_user(carry.pairs, u64_to_user_ptr(req.pairs), n * sizeof(u16))) {
		kvfree(carry.pairs);
		return -EFAULT;
	}
	ret = ct_load(arg, &carry); /* the load request is the first member */
	kvfree(carry.pairs);
	if (ret == 0 &&
	    copy_to_user((void __user *)arg + offsetof(struct contego_kmod_reload, staged_dropped),
			 &carry.staged_dropped, sizeof(carry.staged_dropped)))
		return -EFAULT;
	return ret;
}

/* CONTEGO_KMOD_IMAGE: the image in force, copied out of the lock. */
static long ct_image(unsigned long arg)
{
	struct contego_kmod_image req;
	u8 *copy = NULL;
	long ret = 0;

	if (copy_from_user(&req, (void __user *)arg, sizeof(req)))
		return -EFAULT;
	if (req.size) {
		copy = kvmalloc(min_t(u32, req.size, CONTEGO_KMOD_MAX_IMAGE), GFP_KERNEL);
		if (!copy)
			return -ENOMEM;
	}
	mutex_lock(&ct_lock);
	if (!ct_policy) {
		ret = -ENOENT;
	} else {
		if (ct_policy->size > req.size)
			ret = -ENOSPC;
		else
			memcpy(copy, ct_policy->image, ct_policy->size);
		req.size = ct_policy->size;
		req.crc = ct_image_crc(ct_policy);
	}
	mutex_unlock(&ct_lock);
	if (ret == 0 && copy_to_user(u64_to_user_ptr(req.buf), copy, req.size))
		ret = -EFAULT;
	kvfree(copy);
	if (ret != -ENOENT && copy_to_user((void __user *)arg, &req, sizeof(req)))
		return -EFAULT;
	return ret;
}

static long ct_ctl_ioctl(struct file *file, unsigned int cmd, unsigned long arg)
{
	struct contego_kmod_stats s;
	unsigned int size = _IOC_SIZE(cmd);

	if (!capable(CAP_SYS_ADMIN))
		return -EPERM;
	if (_IOC_TYPE(cmd) != CONTEGO_KMOD_IOC_MAGIC)
		return -ENOTTY;
	switch (_IOC_NR(cmd)) {
	case _IOC_NR(CONTEGO_KMOD_LOAD):
		if (cmd != CONTEGO_KMOD_LOAD) {
			/* Another contego's request (its size is in the number). */
			pr_warn("contego: CONTEGO_KMOD_LOAD of %u bytes refused: this module takes version %u, %zu bytes (use the contego built with it)\n",
				size, CONTEGO_KMOD_LOAD_VERSION, sizeof(struct contego_kmod_load));
			return -EPROTO;
		}
		return ct_load(arg, NULL);
	case _IOC_NR(CONTEGO_KMOD_RELOAD):
		return cmd == CONTEGO_KMOD_RELOAD ? ct_reload(arg) : -EPROTO;
	case _IOC_NR(CONTEGO_KMOD_IMAGE):
		return cmd == CONTEGO_KMOD_IMAGE ? ct_image(arg) : -ENOTTY;
	case _IOC_NR(CONTEGO_KMOD_STATS):
		/* An older contego asks for fewer counters: the ones it knows. */
		if (_IOC_DIR(cmd) != _IOC_READ || size > sizeof(s) ||
		    size < offsetofend(struct contego_kmod_stats, reader))
			return -ENOTTY;
		mutex_lock(&ct_lock);
		spin_lock_irq(&ct_ring_lock);
		s = ct_stats;
		s.reader = ct_reader;
		spin_unlock_irq(&ct_ring_lock);
		mutex_unlock(&ct_lock);
		return copy_to_user((void __user *)arg, &s, size) ? -EFAULT : 0;
	default:
		return -ENOTTY;
	}
}

/* The control and audit requests are laid out alike for 32-bit callers
 * (every __u64 at a multiple of 8, every size a multiple of 8; checked by
 * the test bed's i386 kmod_ctl32): only the argument pointer needs
 * converting, which compat_ptr_ioctl does. */
static const struct file_operations ct_ctl_fops = {
	.owner = THIS_MODULE,
	.unlocked_ioctl = ct_ctl_ioctl,
	.compat_ioctl = compat_ptr_ioctl,
};

static struct miscdevice ct_ctl = {
	.minor = MISC_DYNAMIC_MINOR,
	.name = "contego",
	.fops = &ct_ctl_fops,
	.mode = 0600,
};

/* ---- /dev/contego-audit: the reader's end of the ring --------------------- */

struct ct_reader_file {
	u64 next; /* the next seq this reader is handed */
};

static int ct_audit_open(struct inode *inode, struct file *file)
{
	struct ct_reader_file *rf;

	if (!capable(CAP_SYS_ADMIN))
		return -EPERM;
	rf = kzalloc(sizeof(*rf), GFP_KERNEL);
	if (!rf)
		return -ENOMEM;
	spin_lock_irq(&ct_ring_lock);
	if (ct_reader) {
		spin_unlock_irq(&ct_ring_lock);
		kfree(rf);
		return -EBUSY;
	}
	ct_reader = true;
	rf->next = ct_acked + 1; /* what no reader acknowledged is handed again */
	spin_unlock_irq(&ct_ring_lock);
	file->private_data = rf;
	return 0;
}

static int ct_audit_release(struct inode *inode, struct file *file)
{
	spin_lock_irq(&ct_ring_lock);
	ct_reader = false;
	spin_unlock_irq(&ct_ring_lock);
	kfree(file->private_data);
	return 0;
}

static bool ct_audit_ready(struct ct_reader_file *rf)
{
	bool ready;

	spin_lock_irq(&ct_ring_lock);
	ready = rf->next <= ct_head;
	spin_unlock_irq(&ct_ring_lock);
	return ready;
}

#define CT_READ_BATCH 128

static ssize_t ct_audit_read(struct file *file, char __user *buf, size_t count, loff_t *off)
{
	struct ct_reader_file *rf = file->private_data;
	struct contego_kmod_record *batch;
	u32 n = 0, want = min_t(size_t, count / sizeof(*batch), CT_READ_BATCH);
	int ret;

	if (want == 0)
		return -EINVAL;
	if (!ct_audit_ready(rf)) {
		if (file->f_flags & O_NONBLOCK)
			return -EAGAIN;
		ret = wait_event_interruptible(ct_ring_wait, ct_audit_ready(rf));
		if (ret)
			return ret;
	}
	batch = kmalloc_array(want, sizeof(*batch), GFP_KERNEL);
	if (!batch)
		return -ENOMEM;
	spin_lock_irq(&ct_ring_lock);
	while (n < want && rf->next + n <= ct_head) {
		batch[n] = ct_ring[(rf->next + n - 1) % ct_ring_cap];
		n++;
	}
	spin_unlock_irq(&ct_ring_lock);
	if (copy_to_user(buf, batch, n * sizeof(*batch))) {
		kfree(batch);
		return -EFAULT;
	}
	kfree(batch);
	rf->next += n;
	return n * sizeof(*batch);
}

static __poll_t ct_audit_poll(struct file *file, poll_table *wait)
{
	poll_wait(file, &ct_ring_wait, wait);
	return ct_audit_ready(file->private_data) ? EPOLLIN | EPOLLRDNORM : 0;
}

static long ct_audit_ioctl(struct file *file, unsigned int cmd, unsigned long arg)
{
	struct ct_reader_file *rf = file->private_data;
	u64 seq;

	if (cmd != CONTEGO_KMOD_AUDIT_ACK)
		return -ENOTTY;
	if (copy_from_user(&seq, (void __user *)arg, sizeof(seq)))
		return -EFAULT;
	spin_lock_irq(&ct_ring_lock);
	if (seq >= rf->next) { /* not handed to this reader yet */
		spin_unlock_irq(&ct_ring_lock);
		return -EINVAL;
	}
	if (seq > ct_acked)
		ct_acked = seq;
	spin_unlock_irq(&ct_ring_lock);
	return 0;
}

static const struct file_operations ct_audit_fops = {
	.owner = THIS_MODULE,
	.open = ct_audit_open,
	.release = ct_audit_release,
	.read = ct_audit_read,
	.poll = ct_audit_poll,
	.unlocked_ioctl = ct_audit_ioctl,
	.compat_ioctl = compat_ptr_ioctl,
#if LINUX_VERSION_CODE < KERNEL_VERSION(6, 12, 0)
	.llseek = no_llseek,
#endif
};

static struct miscdevice ct_audit_dev = {
	.minor = MISC_DYNAMIC_MINOR,
	.name = "contego-audit",
	.fops = &ct_audit_fops,
	.mode = 0600,
};

/* ---- module -------------------------------------------------------------- */

static void ct_remove_nodes(void)
{
	int i;

	for (i = 0; i < ct_node_count; i++) {
		if (ct_nodes[i].dev)
			device_destroy(ct_class, MKDEV(I2C_MAJOR, ct_nodes[i].nr));
		if (ct_nodes[i].registered) {
			cdev_del(&ct_nodes[i].cdev);
			unregister_chrdev_region(MKDEV(I2C_MAJOR, ct_nodes[i].nr), 1);
		}
	}
	ct_node_count = 0;
}

static int __init ct_init(void)
{
	int i, ret;

	if (n_adapters == 0) {
		adapters[0] = 0;
		n_adapters = 1;
	}
	/* The record layout `contego kmod audit` reads (kmod_audit.cc asserts it too). */
	BUILD_BUG_ON(sizeof(struct contego_kmod_record) != 136);
	/* CONTEGO_KMOD_LOAD_VERSION 3's layout (kmod_command.cc asserts it too). */
	BUILD_BUG_ON(sizeof(struct contego_kmod_load) != 344);
	if (max_sessions < 1 || max_sessions > 65536) {
		pr_err("contego: max_sessions=%u: give 1 .. 65536\n", max_sessions);
		return -EINVAL;
	}
	if (audit_records < 64 || audit_records > (1u << 20)) {
		pr_err("contego: audit_records=%u: give 64 .. 1048576\n", audit_records);
		return -EINVAL;
	}
	ct_ring_cap = audit_records;
	ct_ring = vmalloc_array(ct_ring_cap, sizeof(*ct_ring));
	if (!ct_ring)
		return -ENOMEM;
	ct_wq = alloc_workqueue("contego", 0, 0);
	if (!ct_wq) {
		vfree(ct_ring);
		return -ENOMEM;
	}
#if LINUX_VERSION_CODE >= KERNEL_VERSION(6, 4, 0)
	ct_class = class_create("i2c-dev");
#else
	ct_class = class_create(THIS_MODULE, "i2c-dev");
#endif
	if (IS_ERR(ct_class)) {
		pr_err("contego: cannot create class i2c-dev (is i2c-dev loaded? contego.ko replaces it)\n");
		destroy_workqueue(ct_wq);
		vfree(ct_ring);
		return PTR_ERR(ct_class);
	}
	ct_class->devnode = ct_devnode;
	ct_class->dev_uevent = ct_dev_uevent;
	for (i = 0; i < n_adapters; i++) {
		struct ct_node *node = &ct_nodes[ct_node_count];
		struct i2c_adapter *adap;
		dev_t devt = MKDEV(I2C_MAJOR, adapters[i]);

		node->nr = adapters[i];
		node->bus = i < n_buses ? buses[i] : adapters[i];
		ct_node_count++;
		adap = i2c_get_adapter(node->nr);
		if (!adap) {
			pr_err("contego: no adapter i2c-%d\n", node->nr);
			ret = -ENODEV;
			goto fail;
		}
		ret = register_chrdev_region(devt, 1, "i2c");
		if (ret) {
			i2c_put_adapter(adap);
			pr_err("contego: char device %d:%d taken (unload i2c-dev first)\n", I2C_MAJOR,
			       node->nr);
			goto fail;
		}
		node->registered = true;
		cdev_init(&node->cdev, &ct_node_fops);
		node->cdev.owner = THIS_MODULE;
		ret = cdev_add(&node->cdev, devt, 1);
		if (ret) {
			i2c_put_adapter(adap);
			unregister_chrdev_region(devt, 1);
			node->registered = false;
			goto fail;
		}
		node->dev = device_create(ct_class, &adap->dev, devt, NULL, "i2c-%d", node->nr);
		i2c_put_adapter(adap);
		if (IS_ERR(node->dev)) {
			ret = PTR_ERR(node->dev);
			node->dev = NULL;
			goto fail;
		}
		pr_info("contego: /dev/i2c-%d checked as the policy's bus %u\n", node->nr, node->bus);
	}
	ret = misc_register(&ct_ctl);
	if (ret)
		goto fail;
	ret = misc_register(&ct_audit_dev);
	if (ret) {
		misc_deregister(&ct_ctl);
		goto fail;
	}
	return 0;
fail:
	ct_remove_nodes();
	class_destroy(ct_class);
	destroy_workqueue(ct_wq);
	vfree(ct_ring);
	return ret;
}

static void __exit ct_exit(void)
{
	misc_deregister(&ct_audit_dev);
	misc_deregister(&ct_ctl);
	/* No session can end from here on (the unload drives every device). */
	ct_sessions_stop();
	/* No node is open (each open holds the module): the actuators go to
	 * their safe state before the checker and the nodes go away. */
	mutex_lock(&ct_lock);
	if (ct_policy)
		pr_info("contego: unloading: %u devices driven to their safe state\n",
			ct_drive_safe_states(ct_policy, CONTEGO_KMOD_SAFE_UNLOAD));
	mutex_unlock(&ct_lock);
	ct_remove_nodes();
	class_destroy(ct_class);
	ct_policy_free(ct_policy);
	ct_policy = NULL;
	vfree(ct_ring);
}

module_init(ct_init);
module_exit(ct_exit);
MODULE_DESCRIPTION("contego: i2c-dev with the trusted core's checks in the kernel");
MODULE_LICENSE("GPL");
