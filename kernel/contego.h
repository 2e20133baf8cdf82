/* SPDX-License-Identifier: GPL-2.0 */
/*
 * contego.ko's own declarations (docs/kernel-client.md): the module's state,
 * one instance (ct), and what its files share. Not a UAPI header: that is
 * contego_kmod.h.
 */
#ifndef CONTEGO_H
#define CONTEGO_H

#include <linux/cdev.h>
#include <linux/cgroup.h>
#include <linux/compat.h>
#include <linux/cred.h>
#include <linux/device.h>
#include <linux/file.h>
#include <linux/fs.h>
#include <linux/hrtimer.h>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <linux/init.h>
#include <linux/ktime.h>
#include <linux/list.h>
#include <linux/lockdep.h>
#include <linux/math64.h>
#include <linux/miscdevice.h>
#include <linux/mm.h>
#include <linux/module.h>
#include <linux/mutex.h>
#include <linux/nsproxy.h>
#include <linux/pid.h>
#include <linux/poll.h>
#include <linux/sched.h>
#include <linux/sched/mm.h>
#include <linux/sched/signal.h>
#include <linux/slab.h>
#include <linux/spinlock.h>
#include <linux/stat.h>
#include <linux/uaccess.h>
#include <linux/vmalloc.h>
#include <linux/wait.h>
#include <linux/workqueue.h>

#include "contego/core_c.h"
#include "contego/i2c_msg_flags.h"
#include "contego/i2c_plan.h"
#include "contego/job_budget.h"
#include "contego_compat.h"
#include "contego/session_room.h"
#include <linux/contego_kmod.h>

#define CT_MAX_ADAPTERS 8
#define CT_MAX_MSGS I2C_RDWR_IOCTL_MAX_MSGS /* 42 */
/* Transfers that did not act a task may send per job, at budget factor 1,
 * before its sender waits (the monitor's kNonActingFloor): room for a vendor
 * library's start-up writes a policy ignores by design.
 */
#define CT_NON_ACTING_FLOOR 8
#define CT_MAX_LEN 8192

/* The latest sample of a sensor (the core's read_sample host callback). */
struct ct_sample {
	u64 taken_us;
	u32 len;
	bool valid; /* false: none yet, or the last read failed */
	u8 bytes[CONTEGO_MAX_SAMPLE_BYTES];
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
	 * its first transaction; job k spans [phase + (k-1)*period, phase + k*period).
	 */
	u64 phase_us[CONTEGO_MAX_TASKS];
	u32 phase_set; /* bit per task */
	struct ct_sample samples[CONTEGO_MAX_DEVICES];
	/* A degraded load's gaps, bit per device: a safe state not driven and
	 * a sensor not read since; each bit cleared when that succeeds.
	 */
	u32 undriven;
	u32 unread;
	/* What the monitor enforces beside the image (from CONTEGO_KMOD_LOAD):
	 * each task's live sessions and actuations per job, and the hold.
	 */
	u32 sessions[CONTEGO_KMOD_MAX_TASKS];
	u32 actuations[CONTEGO_KMOD_MAX_TASKS];
	u32 budget_factor;
	u32 complain; /* bit per task: complain mode (docs/learn.md) */
	u8 ignore_errno[CONTEGO_KMOD_MAX_TASKS]; /* the policy's `ignore_errno`, 0: none */
	/* The over-budget hold: each task's counts in the model the monitor
	 * shares (contego/job_budget.h): its job, the transfers that acted
	 * and those that did not.
	 */
	struct contego_job_budget budget[CONTEGO_KMOD_MAX_TASKS];
	u32 holds_unreported[CONTEGO_KMOD_MAX_TASKS];
	u64 hold_reported_us[CONTEGO_KMOD_MAX_TASKS];
	u32 hold_told; /* bit per task: the first hold is in the kernel log */
	/* Calls refused for want of room for a session (max_sessions), as
	 * the holds: audited at most once a second per task.
	 */
	u32 full_unreported[CONTEGO_KMOD_MAX_TASKS];
	u64 full_reported_us[CONTEGO_KMOD_MAX_TASKS];
};


struct ct_node {
	int nr;  /* adapter number */
	u8 bus;  /* policy bus */
	struct cdev cdev;
	struct device *dev; /* NULL while the adapter is away */
	bool registered;
	bool returned; /* the adapter came back: its devices' safe state is due */
};

struct ct_file {
	struct i2c_adapter *adap;
	u8 bus;
	u16 addr;
	u16 flags; /* I2C_M_TEN, I2C_CLIENT_PEC */
	/* I2C_RETRIES and I2C_TIMEOUT of this descriptor alone (own_timing),
	 * applied to its transfers only (ct_bus_transfer), never adapter-wide.
	 */
	bool own_timing;
	int retries;
	unsigned long timeout; /* jiffies */
};

enum { CT_S_PROCESS = 0, CT_S_LEADER = 1 };

struct ct_session {
	struct list_head node; /* ct.sessions, under ct.lock */
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

/* ct_decide()'s answer: the core's transfer action. */
enum { CT_PERFORM = 0, CT_REFUSE = 1, CT_IGNORE = 2, CT_SUBSTITUTE = 3, CT_SAFE_STATE = 4 };

/* The audit ring (contego_audit.c): records seq acked+1 .. head are in it,
 * record s at (s - 1) % cap. Its lock covers the ring, the reader flag and
 * the gap count; the producers also hold ct.lock (one decision at a time).
 */
struct ct_ring {
	spinlock_t lock;
	wait_queue_head_t wait;
	struct contego_kmod_record *records;
	u32 cap;
	u64 head, acked;
	bool reader;
	u64 gap; /* records lost since the last one taken */
};

/*
 * The module's state. One decision at a time (the core is not thread-safe):
 * ct.lock covers the checks of a call and its bus operations, as the
 * user-space monitor's lock does, and every member below it but the ring.
 */
struct ct_state {
	struct mutex lock;
	struct ct_policy *policy; /* the policy in force, NULL: none loaded */
	u64 gen;                  /* loads so far */
	struct contego_kmod_stats stats;
	/* The call being decided: whether it complains (complain mode), and
	 * whether a record of it could not be taken (the core's audit callback).
	 */
	bool complain_now;
	bool audit_lost;
	/* The safe state was driven for the current run of lost records. */
	bool failing_closed;
	/* Scratch for one call (kept off the 16 KiB kernel stack). */
	struct contego_i2c_tx txs[CT_MAX_MSGS]; /* a call's transactions (contego/i2c_plan.h) */
	contego_verdict verdicts[CT_MAX_MSGS];
	contego_verdict safe_verdict;
	char cgroup_buf[PATH_MAX];
	struct contego_session_room room; /* a session room count (contego/session_room.h) */
	/* Sessions (contego_session.c). */
	struct list_head sessions;
	u32 session_count;
	bool unloading;
	struct workqueue_struct *wq;
	/* The protected adapters (contego_main.c), fixed after init. */
	struct ct_node nodes[CT_MAX_ADAPTERS];
	int node_count;
	struct class *i2c_class;
	struct work_struct adapter_work; /* the safe state on adapters that came back */
	struct ct_ring ring;
};

extern struct ct_state ct;

/* Module parameters (contego_main.c). */
extern bool ct_trace;
extern unsigned int ct_max_sessions;

/* The file operations and devices contego_main.c registers. */
extern const struct file_operations ct_node_fops;
extern struct miscdevice ct_ctl;
extern struct miscdevice ct_audit_dev;

/* contego_node.c */
struct ct_node *ct_node_for_bus(u8 bus);

/* contego_xfer.c */
long ct_rdwr_msgs(struct ct_file *cf, struct i2c_msg *msgs, u32 nmsgs);
long ct_rdwr(struct ct_file *cf, unsigned long arg);
long ct_smbus(struct ct_file *cf, struct i2c_smbus_ioctl_data a);

/* contego_hold.c */
u32 ct_job(struct ct_policy *p, u16 task, u64 now);
int ct_enter(bool writes, u16 *task);
u64 ct_charge_after(struct ct_policy *p, u16 task, bool acted);
void ct_hold_after(u64 until);

/* contego_bind.c */
u16 ct_task_of_current(const struct ct_policy *p);
bool ct_msg_expressible(struct ct_file *cf, struct i2c_msg *m);

/* contego_audit.c */
bool ct_push(struct contego_kmod_record *r, bool acting);
void ct_record_start(struct contego_kmod_record *r, u8 type, bool caller);
void ct_audit(void *context, const contego_audit_record *a);
void ct_record_formless(u16 task, u8 bus, u32 funcs, const struct contego_i2c_formless *why);

/* contego_bus.c */
int ct_bus_transfer(struct i2c_adapter *adap, const struct ct_file *cf, struct i2c_msg *m, int n);
int ct_bus_smbus(struct i2c_adapter *adap, const struct ct_file *cf, u16 addr, u16 flags,
		 char read_write, u8 command, int size, union i2c_smbus_data *data);
int ct_xfer(struct i2c_adapter *adap, const struct ct_file *cf, struct i2c_msg *m, u32 n,
	    bool check_only);
int ct_perform_emits(struct i2c_adapter *adap, const struct ct_file *cf,
		     const contego_verdict *v, u16 flags);
bool ct_emit_with_read(struct i2c_adapter *adap, const struct ct_file *cf,
		       const contego_verdict *v, struct i2c_msg *read, int *ret);
int ct_drive_safe_state_of(struct ct_policy *p, u16 d, u8 why, const struct ct_session *s);
bool ct_drive_safe_state(struct ct_policy *p, u16 d, u8 why);
u32 ct_drive_safe_states(struct ct_policy *p, u8 why, u32 *failed);
u32 ct_drive_safe_states_on(struct ct_policy *p, u8 bus, u8 why);
u32 ct_safe_states_formless(struct ct_policy *p);

/* contego_sample.c */
u32 ct_read_sample(void *context, u16 device, u8 *buf, u32 capacity, u64 *taken_at_us);
u32 ct_sample_all(struct ct_policy *p);

/* contego_session.c */
void ct_session_record(struct contego_kmod_record *r, const struct ct_session *s);
void ct_session_free(struct ct_session *s);
struct ct_session *ct_session_find(struct ct_policy *p, u16 task);
bool ct_session_room(struct ct_policy *p, u16 task);
struct ct_session *ct_session_prepare(struct ct_policy *p, u16 task);
void ct_session_open(struct ct_session *s);
void ct_sessions_stop(void);
void ct_record_session_refused(struct ct_policy *p, u16 task);
void ct_record_sessions_full(struct ct_policy *p, u16 task, u64 now);

/* contego_decide.c */
bool ct_call_writes(u32 checked);
u8 ct_decide(struct ct_file *cf, u16 task, const struct i2c_msg *msgs, u32 nmsgs, u32 n,
	     u32 *decider, u64 *hold_until);
int ct_refusal(u32 decider);

/* contego_policy.c */
void ct_policy_free(struct ct_policy *p);
void ct_seed_shadows(struct ct_policy *p, int bus);

#endif /* CONTEGO_H */
