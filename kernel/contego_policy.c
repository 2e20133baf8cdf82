// SPDX-License-Identifier: GPL-2.0
/* contego.ko: /dev/contego: policy load, load in place, the image in force, the counters. */
#include "contego.h"

void ct_policy_free(struct ct_policy *p)
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
 * live, so the safe state and the first checks see what the chip holds; and
 * for the devices of an adapter that came back (`bus`; -1: every bus), under
 * ct.lock, since the policy is live then.
 */
void ct_seed_shadows(struct ct_policy *p, int bus)
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
		if (n == 0 || !contego_device_info_of(p->checker, d, &info) ||
		    (bus >= 0 && info.bus != bus))
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
 * the audit ring's LOAD records and what a load in place is paired against.
 */
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
 * reload requires): else -EBUSY.
 */
static int ct_carry_locked(struct ct_policy *p, const struct ct_policy *old, struct ct_carry *c)
{
	contego_carry_map map;
	struct ct_session *s;
	u32 t, d;

	lockdep_assert_held(&ct.lock);
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
	list_for_each_entry(s, &ct.sessions, node) {
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
		p->budget[t] = old->budget[o];
	}
	p->undriven = old->undriven; /* the same devices, in their order */
	p->unread = old->unread;
	for (d = 0; d < c->counts[1] && d < ARRAY_SIZE(p->samples); d++)
		if (map.devices[d] < ARRAY_SIZE(old->samples))
			p->samples[d] = old->samples[map.devices[d]];
	list_for_each_entry(s, &ct.sessions, node)
		if (s->gen == old->gen)
			s->gen = p->gen; /* the same task id: checked above */
	return 0;
}

/* The record of an image taken into force: its header's CRC-32, so that a
 * reader names the records that follow from this image alone; in place
 * (`replaced`), the one it replaced too. Under ct.lock.
 */
static void ct_record_load(struct ct_policy *p, struct ct_policy *replaced)
{
	struct contego_kmod_record rec;

	ct_record_start(&rec, CONTEGO_KMOD_REC_LOAD, true);
	rec.count = p->size;
	rec.fields[0] = (s32)ct_image_crc(p);
	rec.field_count = 1;
	if (replaced) {
		rec.fields[1] = (s32)ct_image_crc(replaced);
		rec.field_count = 2;
	}
	ct_push(&rec, true);
}

/* p withdrawn after its load record: sensors it could not read, or devices
 * whose safe state it could not drive (req); the image in force again
 * (`kept`, if any) in fields[2], so that a reader names what follows from
 * it. Under ct.lock.
 */
static void ct_record_unsafe_load(struct ct_policy *p, struct ct_policy *kept,
				  const struct contego_kmod_load *req)
{
	struct contego_kmod_record rec;

	lockdep_assert_held(&ct.lock);
	ct.stats.refused_loads++;
	ct_record_start(&rec, CONTEGO_KMOD_REC_LOAD_REFUSED, true);
	rec.reason = CONTEGO_KMOD_REFUSED_UNSAFE;
	rec.count = p->size;
	rec.fields[0] = (s32)req->unsafe;
	rec.fields[1] = (s32)req->unreadable;
	rec.field_count = 2;
	if (kept) {
		rec.fields[2] = (s32)ct_image_crc(kept);
		rec.field_count = 3;
	}
	ct_push(&rec, true);
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
	    req.ntasks > CONTEGO_KMOD_MAX_TASKS || (req.flags & ~CONTEGO_KMOD_LOAD_DEGRADED) ||
	    (carry && req.flags) || req.pad)
		return -EINVAL;
	req.unsafe = 0;
	req.unreadable = 0;
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

		mutex_lock(&ct.lock);
		ct.stats.refused_loads++;
		ct_record_start(&rec, CONTEGO_KMOD_REC_LOAD_REFUSED, true);
		rec.reason = r.status;
		rec.count = req.size;
		ct_push(&rec, false);
		mutex_unlock(&ct.lock);
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
	 * bind its processes to nothing the policy decides about.
	 */
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
	ct_seed_shadows(p, -1);
	if (mutex_lock_killable(&ct.lock)) {
		ret = -EINTR;
		goto fail;
	}
	old = ct.policy;
	/* As the monitor starts: the first sample of every sensor, then every
	 * actuator in the new policy's safe state, before it takes over (in
	 * place, the actuators keep what the running policy let them do). A
	 * sensor that cannot be read, or an actuator that cannot be driven
	 * (absent, or no form on its adapter), would leave the policy blind or
	 * unable to make it safe: refused, as the monitor refuses to start,
	 * unless the caller asked for a degraded load. The load record goes
	 * first: the records that follow carry its names.
	 */
	if (!carry) {
		bool degraded = req.flags & CONTEGO_KMOD_LOAD_DEGRADED;

		ct_record_load(p, NULL);
		req.unreadable = ct_sample_all(p);
		if (!req.unreadable || degraded)
			req.devices = ct_drive_safe_states(p, CONTEGO_KMOD_SAFE_LOAD, &req.unsafe);
		p->unread = req.unreadable;
		p->undriven = req.unsafe;
		if ((req.unreadable || req.unsafe) && !degraded) {
			ct_record_unsafe_load(p, old, &req);
			mutex_unlock(&ct.lock);
			pr_warn("contego: policy refused: sensor(s) 0x%x could not be read, the safe state of device(s) 0x%x could not be driven; the policy in force stays\n",
				req.unreadable, req.unsafe);
			ret = -EIO;
			goto fail;
		}
	}
	/* In place, no safe state is driven: each must at least have a form on
	 * its adapter, or a fail-safe of the new policy would act nothing.
	 */
	if (carry) {
		req.unsafe = ct_safe_states_formless(p);
		if (req.unsafe) {
			ct_record_load(p, old);
			ct_record_unsafe_load(p, old, &req);
			mutex_unlock(&ct.lock);
			pr_warn("contego: load in place refused: the safe state of device(s) 0x%x has no form on its adapter; the policy in force stays\n",
				req.unsafe);
			ret = -EIO;
			goto fail;
		}
	}
	p->gen = ++ct.gen;
	if (carry) {
		ret = ct_carry_locked(p, old, carry);
		if (ret) {
			mutex_unlock(&ct.lock);
			goto fail;
		}
		ct_record_load(p, old);
	}
	ct.policy = p;
	ct.stats.loads++;
	ct.stats.loaded = 1;
	mutex_unlock(&ct.lock);
	ct_policy_free(old);
	if (carry)
		pr_info("contego: policy loaded in place (%u bytes, %u bindings, state carried over, %u staged writes dropped, no safe state driven, budget factor %u)\n",
			req.size, req.nbinds, carry->staged_dropped, req.budget_factor);
	else
		pr_info("contego: policy loaded (%u bytes, %u bindings, %u devices in their safe state, budget factor %u)%s\n",
			req.size, req.nbinds, req.devices, req.budget_factor,
			req.unsafe || req.unreadable ?
			", degraded: a sensor not read or a safe state not driven" : "");
	if (copy_to_user((void __user *)arg, &req, sizeof(req)))
		return -EFAULT;
	return 0;
fail:
	ct_policy_free(p);
	if ((req.status != 0 || req.unsafe || req.unreadable) &&
	    copy_to_user((void __user *)arg, &req, sizeof(req)))
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

/* CONTEGO_KMOD_RESET: an operator's reset of a latched device, as the
 * monitor's `contego reset`: no reset without its record.
 */
static long ct_reset(unsigned long arg)
{
	struct contego_kmod_reset req;
	struct contego_kmod_record rec;
	contego_device_info info;
	long ret = 0;

	if (copy_from_user(&req, (void __user *)arg, sizeof(req)))
		return -EFAULT;
	if (req.pad || req.device >= CONTEGO_MAX_DEVICES)
		return -EINVAL;
	if (mutex_lock_killable(&ct.lock))
		return -EINTR;
	if (!ct.policy) {
		ret = -ENOENT;
	} else if (ct_image_crc(ct.policy) != req.crc) {
		ret = -ESTALE;
	} else if (!contego_device_info_of(ct.policy->checker, req.device, &info)) {
		ret = -EINVAL;
	} else {
		req.was_latched = contego_latched(ct.policy->checker, req.device) ? 1 : 0;
		ct_record_start(&rec, CONTEGO_KMOD_REC_RESET, true);
		rec.device = req.device;
		rec.bus = info.bus;
		rec.addr = info.addr;
		rec.index = req.was_latched;
		if (ct_push(&rec, true))
			contego_reset_latch(ct.policy->checker, req.device);
		else
			ret = -EIO;
	}
	mutex_unlock(&ct.lock);
	if (ret == 0 && copy_to_user((void __user *)arg, &req, sizeof(req)))
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
	if (mutex_lock_killable(&ct.lock)) {
		kvfree(copy);
		return -EINTR;
	}
	if (!ct.policy) {
		ret = -ENOENT;
	} else {
		if (ct.policy->size > req.size)
			ret = -ENOSPC;
		else
			memcpy(copy, ct.policy->image, ct.policy->size);
		req.size = ct.policy->size;
		req.crc = ct_image_crc(ct.policy);
	}
	mutex_unlock(&ct.lock);
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
	u32 latched = 0;
	u16 i;

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
	case _IOC_NR(CONTEGO_KMOD_RESET):
		return cmd == CONTEGO_KMOD_RESET ? ct_reset(arg) : -ENOTTY;
	case _IOC_NR(CONTEGO_KMOD_STATS):
		/* An older contego asks for fewer counters: the ones it knows. */
		if (_IOC_DIR(cmd) != _IOC_READ || size > sizeof(s) ||
		    size < offsetofend(struct contego_kmod_stats, reader))
			return -ENOTTY;
		if (mutex_lock_killable(&ct.lock))
			return -EINTR;
		for (i = 0; ct.policy && i < CONTEGO_MAX_DEVICES; i++)
			if (contego_latched(ct.policy->checker, i))
				latched |= BIT(i);
		spin_lock_irq(&ct.ring.lock);
		s = ct.stats;
		s.reader = ct.ring.reader;
		spin_unlock_irq(&ct.ring.lock);
		s.undriven = ct.policy ? ct.policy->undriven : 0;
		s.unread = ct.policy ? ct.policy->unread : 0;
		s.latched = latched;
		mutex_unlock(&ct.lock);
		return copy_to_user((void __user *)arg, &s, size) ? -EFAULT : 0;
	default:
		return -ENOTTY;
	}
}

/* The control and audit requests are laid out alike for 32-bit callers
 * (every __u64 at a multiple of 8, every size a multiple of 8; checked by
 * the test bed's i386 kmod_ctl32): only the argument pointer needs
 * converting, which compat_ptr_ioctl does.
 */
static const struct file_operations ct_ctl_fops = {
	.owner = THIS_MODULE,
	.unlocked_ioctl = ct_ctl_ioctl,
	.compat_ioctl = compat_ptr_ioctl,
};

struct miscdevice ct_ctl = {
	.minor = MISC_DYNAMIC_MINOR,
	.name = "contego",
	.fops = &ct_ctl_fops,
	.mode = 0600,
};
