// SPDX-License-Identifier: GPL-2.0
/* contego.ko: bus operations: a verdict's writes, and the devices' safe states. */
#include "contego.h"

/* i2c_transfer and i2c_smbus_xfer for a descriptor `cf` that set its own
 * I2C_RETRIES or I2C_TIMEOUT: the adapter's values swapped for the call's
 * under the adapter's bus lock, so no other caller's transfer sees them
 * (i2c-dev sets them adapter-wide). `cf` NULL: the module's own transfers.
 */
static void ct_swap_timing(struct i2c_adapter *adap, int *retries, unsigned long *timeout)
{
	swap(adap->retries, *retries);
	swap(adap->timeout, *timeout);
}

int ct_bus_transfer(struct i2c_adapter *adap, const struct ct_file *cf, struct i2c_msg *m, int n)
{
	unsigned long timeout;
	int ret, retries;

	if (!cf || !cf->own_timing)
		return i2c_transfer(adap, m, n);
	retries = cf->retries;
	timeout = cf->timeout;
	i2c_lock_bus(adap, I2C_LOCK_SEGMENT);
	ct_swap_timing(adap, &retries, &timeout);
	ret = __i2c_transfer(adap, m, n);
	ct_swap_timing(adap, &retries, &timeout);
	i2c_unlock_bus(adap, I2C_LOCK_SEGMENT);
	return ret;
}

int ct_bus_smbus(struct i2c_adapter *adap, const struct ct_file *cf, u16 addr, u16 flags,
		 char read_write, u8 command, int size, union i2c_smbus_data *data)
{
	unsigned long timeout;
	int ret, retries;

	if (!cf || !cf->own_timing)
		return i2c_smbus_xfer(adap, addr, flags, read_write, command, size, data);
	retries = cf->retries;
	timeout = cf->timeout;
	i2c_lock_bus(adap, I2C_LOCK_SEGMENT);
	ct_swap_timing(adap, &retries, &timeout);
	ret = __i2c_smbus_xfer(adap, addr, flags, read_write, command, size, data);
	ct_swap_timing(adap, &retries, &timeout);
	i2c_unlock_bus(adap, I2C_LOCK_SEGMENT);
	return ret;
}

/* One combined transfer in the form the shared i2c-dev model gives it on
 * this adapter (contego/i2c_plan.h, the planner the monitor's buses use):
 * plain I2C, or the one SMBus transaction that puts the same bytes on the
 * wire, with `cf`'s timing (ct_bus_transfer). The messages are the wire's
 * bytes whole: an SMBus form goes without I2C_CLIENT_PEC, so that no byte
 * the core did not check is added (a PEC the program asked for is already
 * one of them: contego_i2c_smbus_msgs).
 * `check_only`: whether it has a form, nothing sent. 0 or -errno
 * (-EOPNOTSUPP: no form on this adapter).
 */
int ct_xfer(struct i2c_adapter *adap, const struct ct_file *cf, struct i2c_msg *m, u32 n,
	    bool check_only)
{
	struct contego_i2c_plan plan;
	union i2c_smbus_data data;
	u8 reply[CONTEGO_SMBUS_DATA_BYTES];
	u32 i;
	int ret;

	/* The planner reads struct i2c_msg as its own contego_i2c_msg. */
	BUILD_BUG_ON(sizeof(struct contego_i2c_msg) != sizeof(struct i2c_msg));
	BUILD_BUG_ON(offsetof(struct contego_i2c_msg, len) != offsetof(struct i2c_msg, len));
	BUILD_BUG_ON(offsetof(struct contego_i2c_msg, buf) != offsetof(struct i2c_msg, buf));
	BUILD_BUG_ON(sizeof(data) != CONTEGO_SMBUS_DATA_BYTES);
	contego_i2c_plan_transfer((struct contego_i2c_msg *)m, n, i2c_get_functionality(adap),
				  &plan);
	if (plan.form == CONTEGO_I2C_FORM_REFUSED)
		return -EOPNOTSUPP;
	if (check_only)
		return 0;
	if (plan.form == CONTEGO_I2C_FORM_I2C) {
		/* i2c-dev's RECV_LEN: the driver counts on from buf[0]'s preset. */
		for (i = 0; i < n; i++)
			if (m[i].flags & I2C_M_RECV_LEN)
				m[i].len = m[i].buf[0];
		ret = ct_bus_transfer(adap, cf, m, n);
		return ret == n ? 0 : (ret < 0 ? ret : -EIO);
	}
	memcpy(data.block, plan.op.data, sizeof(data.block));
	if (plan.op.size == I2C_SMBUS_WORD_DATA || plan.op.size == I2C_SMBUS_PROC_CALL)
		data.word = plan.op.data[0] | (plan.op.data[1] << 8);
	ret = ct_bus_smbus(adap, cf, plan.op.addr, 0,
			   plan.op.read ? I2C_SMBUS_READ : I2C_SMBUS_WRITE, plan.op.command,
			   plan.op.size, &data);
	if (ret < 0 || plan.op.reply < 0)
		return ret < 0 ? ret : 0;
	memcpy(reply, data.block, sizeof(reply));
	if (plan.op.size == I2C_SMBUS_WORD_DATA || plan.op.size == I2C_SMBUS_PROC_CALL) {
		reply[0] = data.word & 0xff;
		reply[1] = data.word >> 8;
	}
	return -contego_i2c_deliver_reply(&plan.op, reply, (struct contego_i2c_msg *)m, n);
}

/* The writes a verdict allows or substitutes, in order, at the verdict's
 * address, each one message in its form (ct_xfer), with `cf`'s timing.
 */
int ct_perform_emits(struct i2c_adapter *adap, const struct ct_file *cf,
		     const contego_verdict *v, u16 flags)
{
	u32 off = 0, i;
	int ret;

	for (i = 0; i < v->emit_count && i < CONTEGO_MAX_EMITS; i++) {
		u32 len = v->emit_len[i];
		struct i2c_msg m = { .addr = v->addr, .flags = flags & I2C_M_TEN, .len = len,
				     .buf = (u8 *)v->emit_bytes + off };

		if (off + len > CONTEGO_MAX_EMIT_BYTES)
			return -EIO; /* malformed verdict: fail closed */
		ret = ct_xfer(adap, cf, &m, 1, false);
		if (ret < 0)
			return ret;
		off += len;
	}
	return 0;
}

/* A write's one emit and the read of the same call that answers it
 * (contego_i2c_write_then_read: a process call) as one transfer, with a
 * repeated start as the program sent them, when the pair has a form on the
 * adapter. True: sent, *ret its result (the read's length updated); false:
 * not joinable, nothing sent, the two go apart.
 */
bool ct_emit_with_read(struct i2c_adapter *adap, const struct ct_file *cf,
		       const contego_verdict *v, struct i2c_msg *read, int *ret)
{
	struct i2c_msg m[2];

	/* The shared model's rule, the monitor's too. */
	if (!contego_i2c_emit_with_read(v, (const struct contego_i2c_msg *)read,
					i2c_get_functionality(adap), (struct contego_i2c_msg *)&m[0]))
		return false;
	m[1] = *read;
	*ret = ct_xfer(adap, cf, m, 2, false);
	read->len = m[1].len;
	return true;
}

/* The adapter of the policy's bus `bus` (i2c_put_adapter it), or NULL. */
static struct i2c_adapter *ct_adapter_of(u8 bus)
{
	struct ct_node *node = ct_node_for_bus(bus);

	return node ? i2c_get_adapter(node->nr) : NULL;
}

/* Device d's declared safe state, written and recorded (best effort: the
 * record may be lost, then counted in the gap). `s`: the session whose end
 * drives it (its task and process go into the record), or NULL. Under
 * ct.lock. 1: written; 0: the write failed; -1: d has no safe state.
 */
int ct_drive_safe_state_of(struct ct_policy *p, u16 d, u8 why, const struct ct_session *s)
{
	struct contego_kmod_record r;
	contego_device_info info;
	struct i2c_adapter *adap;
	bool done = false;

	lockdep_assert_held(&ct.lock);
	if (!contego_device_info_of(p->checker, d, &info) ||
	    !contego_safe_state(p->checker, d, &ct.safe_verdict))
		return -1;
	adap = ct_adapter_of(ct.safe_verdict.bus);
	if (adap) {
		/* A 10-bit device's safe state goes to its 10-bit address. */
		done = ct_perform_emits(adap, NULL, &ct.safe_verdict,
					info.ten_bit ? I2C_M_TEN : 0) == 0;
		i2c_put_adapter(adap);
	}
	if (done)
		p->undriven &= ~BIT(d);
	else
		pr_warn("contego: safe state of device %u failed\n", d);
	ct_record_start(&r, CONTEGO_KMOD_REC_SAFE_STATE, why != CONTEGO_KMOD_SAFE_UNLOAD &&
							    why != CONTEGO_KMOD_SAFE_LOAD);
	r.device = d;
	r.bus = ct.safe_verdict.bus;
	r.addr = ct.safe_verdict.addr;
	r.why = why | (done ? 0 : CONTEGO_KMOD_SAFE_FAILED);
	r.substitute_len = ct.safe_verdict.emit_bytes_used;
	memcpy(r.substitute, ct.safe_verdict.emit_bytes,
	       min_t(u32, ct.safe_verdict.emit_bytes_used, CONTEGO_KMOD_REC_BYTES));
	if (s)
		ct_session_record(&r, s);
	ct_push(&r, true);
	return done;
}

bool ct_drive_safe_state(struct ct_policy *p, u16 d, u8 why)
{
	return ct_drive_safe_state_of(p, d, why, NULL) > 0;
}

/* The safe state of every device on the policy's bus `bus`. Returns how
 * many were written.
 */
u32 ct_drive_safe_states_on(struct ct_policy *p, u8 bus, u8 why)
{
	contego_device_info info;
	u32 n = 0;
	u16 d;

	lockdep_assert_held(&ct.lock);
	for (d = 0; d < CONTEGO_MAX_DEVICES; d++)
		if (contego_device_info_of(p->checker, d, &info) && info.bus == bus)
			n += ct_drive_safe_state(p, d, why);
	return n;
}

/* Every device's safe state. Under ct.lock. Returns how many were written;
 * `failed` (or NULL) gets bit d for a device d whose safe state was not.
 */
u32 ct_drive_safe_states(struct ct_policy *p, u8 why, u32 *failed)
{
	u32 n = 0;
	u16 d;
	int done;

	lockdep_assert_held(&ct.lock);
	for (d = 0; d < CONTEGO_MAX_DEVICES; d++) {
		done = ct_drive_safe_state_of(p, d, why, NULL);
		if (done > 0)
			n++;
		else if (done == 0 && failed)
			*failed |= 1u << d;
	}
	return n;
}

/* The devices of p whose safe state has no form on its adapter: what a
 * load in place, which drives none, checks instead, as the monitor's reload
 * does (the model left as it was). An adapter that is away is no new gap
 * (the same device on the same bus is in force): its return drives the
 * safe state. Under ct.lock.
 */
u32 ct_safe_states_formless(struct ct_policy *p)
{
	struct contego_i2c_formless why;
	contego_device_info info;
	struct i2c_adapter *adap;
	u32 formless = 0;
	u16 d;

	lockdep_assert_held(&ct.lock);
	for (d = 0; d < CONTEGO_MAX_DEVICES; d++) {
		if (!contego_device_info_of(p->checker, d, &info) ||
		    !contego_preview_safe_state(p->checker, d, &ct.safe_verdict))
			continue;
		adap = ct_adapter_of(info.bus);
		if (!adap)
			continue;
		if (!contego_i2c_emits_have_forms(&ct.safe_verdict, info.ten_bit ? I2C_M_TEN : 0,
						  i2c_get_functionality(adap), &why))
			formless |= BIT(d);
		i2c_put_adapter(adap);
	}
	return formless;
}
