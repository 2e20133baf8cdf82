// SPDX-License-Identifier: GPL-2.0
/* contego.ko: the audit ring and /dev/contego-audit, its reader's end. */
#include "contego.h"

/* Takes one record (seq assigned here), first the gap record if records were
 * lost before it. False: not taken (no reader, the ring full); it is counted
 * in the gap. A record of something that acts nothing (a refused or ignored
 * command, `acting` false) may use only three quarters of the ring: a flood
 * of refused calls cannot take the room the records of actions need.
 */
bool ct_push(struct contego_kmod_record *r, bool acting)
{
	unsigned long flags;
	u32 room;
	bool ok;

	spin_lock_irqsave(&ct.ring.lock, flags);
	room = ct.ring.cap - (u32)(ct.ring.head - ct.ring.acked);
	if (!acting)
		room = room > ct.ring.cap / 4 ? room - ct.ring.cap / 4 : 0;
	ok = ct.ring.reader && room >= (ct.ring.gap ? 2u : 1u);
	if (ok && ct.ring.gap) {
		struct contego_kmod_record *g = &ct.ring.records[ct.ring.head % ct.ring.cap];

		memset(g, 0, sizeof(*g));
		g->seq = ++ct.ring.head;
		g->time_us = r->time_us;
		g->type = CONTEGO_KMOD_REC_GAP;
		g->count = (u32)min_t(u64, ct.ring.gap, U32_MAX);
		ct.ring.gap = 0;
	}
	if (ok) {
		r->seq = ++ct.ring.head;
		ct.ring.records[(r->seq - 1) % ct.ring.cap] = *r;
		ct.stats.records++;
	} else {
		ct.ring.gap++;
		ct.stats.unrecorded++;
	}
	spin_unlock_irqrestore(&ct.ring.lock, flags);
	if (ok)
		wake_up_interruptible(&ct.ring.wait);
	return ok;
}

void ct_record_start(struct contego_kmod_record *r, u8 type, bool caller)
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
 * contego_check (under ct.lock).
 */
void ct_audit(void *context, const contego_audit_record *a)
{
	struct contego_kmod_record r;
	u32 n;

	lockdep_assert_held(&ct.lock);
	ct_record_start(&r, CONTEGO_KMOD_REC_DECISION, true);
	if (ct.complain_now)
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
	 * all the same.
	 */
	if (!ct_push(&r, a->decision == CONTEGO_ALLOW || a->decision == CONTEGO_FAILSAFE))
		ct.audit_lost |= a->decision == CONTEGO_ALLOW || a->decision == CONTEGO_FAILSAFE;
}

/* A call refused before anything of it acted: `why`, a part of what its
 * verdicts would send, has no form on the adapter (I2C_FUNCS `funcs`).
 * The reader words it as the monitor does (`inexpressible`). Under ct.lock.
 */
void ct_record_formless(u16 task, u8 bus, u32 funcs, const struct contego_i2c_formless *why)
{
	const struct contego_i2c_plan *p = &why->plan;
	struct contego_kmod_record r;
	u32 i, n = min_t(u32, why->n, 2);

	lockdep_assert_held(&ct.lock);
	ct.stats.inexpressible++;
	ct_record_start(&r, CONTEGO_KMOD_REC_INEXPRESSIBLE, true);
	r.task = task;
	r.bus = bus;
	r.addr = why->msgs[0].addr;
	r.reason = p->refusal;
	r.index = n;
	for (i = 0; i < n; i++)
		r.fields[i] = (s32)((u32)why->msgs[i].len << 16 | why->msgs[i].flags);
	r.fields[2] = (s32)funcs;
	r.fields[3] = p->flags;
	r.fields[4] = (s32)(p->candidates_read | (u32)p->candidate_count << 8 |
			    (u32)p->candidates[0] << 16 | (u32)p->candidates[1] << 24);
	r.fields[5] = p->candidates[2];
	r.field_count = 6;
	/* Nothing acted: taken or counted in the gap, refused all the same. */
	ct_push(&r, false);
}

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
	spin_lock_irq(&ct.ring.lock);
	if (ct.ring.reader) {
		spin_unlock_irq(&ct.ring.lock);
		kfree(rf);
		return -EBUSY;
	}
	ct.ring.reader = true;
	rf->next = ct.ring.acked + 1; /* what no reader acknowledged is handed again */
	spin_unlock_irq(&ct.ring.lock);
	file->private_data = rf;
	return 0;
}

static int ct_audit_release(struct inode *inode, struct file *file)
{
	spin_lock_irq(&ct.ring.lock);
	ct.ring.reader = false;
	spin_unlock_irq(&ct.ring.lock);
	kfree(file->private_data);
	return 0;
}

static bool ct_audit_ready(struct ct_reader_file *rf)
{
	bool ready;

	spin_lock_irq(&ct.ring.lock);
	ready = rf->next <= ct.ring.head;
	spin_unlock_irq(&ct.ring.lock);
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
		ret = wait_event_interruptible(ct.ring.wait, ct_audit_ready(rf));
		if (ret)
			return ret;
	}
	batch = kmalloc_array(want, sizeof(*batch), GFP_KERNEL);
	if (!batch)
		return -ENOMEM;
	spin_lock_irq(&ct.ring.lock);
	while (n < want && rf->next + n <= ct.ring.head) {
		batch[n] = ct.ring.records[(rf->next + n - 1) % ct.ring.cap];
		n++;
	}
	spin_unlock_irq(&ct.ring.lock);
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
	poll_wait(file, &ct.ring.wait, wait);
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
	spin_lock_irq(&ct.ring.lock);
	if (seq >= rf->next) { /* not handed to this reader yet */
		spin_unlock_irq(&ct.ring.lock);
		return -EINVAL;
	}
	if (seq > ct.ring.acked)
		ct.ring.acked = seq;
	spin_unlock_irq(&ct.ring.lock);
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
	.llseek = CT_NO_LLSEEK,
};

struct miscdevice ct_audit_dev = {
	.minor = MISC_DYNAMIC_MINOR,
	.name = "contego-audit",
	.fops = &ct_audit_fops,
	.mode = 0600,
};
