// SPDX-License-Identifier: GPL-2.0
/* contego.ko: I2C_RDWR and I2C_SMBUS: a call's messages as the core's transactions, decided, then sent. */
#include "contego.h"

/* ---- I2C_RDWR ------------------------------------------------------------ */

/* The call's transactions in ct.txs, by the normalisation every client
 * shares (contego/i2c_plan.h): a one-byte write then a read of the same
 * address is that read's register pointer. Returns how many.
 */
static u32 ct_plan_msgs(const struct i2c_msg *m, u32 n)
{
	lockdep_assert_held(&ct.lock);
	return contego_i2c_transactions((const struct contego_i2c_msg *)m, n, ct.txs);
}

/* Every transaction of the call has a form on this adapter, as the monitor
 * asks before the core decides: the shared model's rule
 * (contego_i2c_call_has_forms) on the program's bytes. A refusal is
 * recorded, naming the caller's task, as the monitor audits it.
 */
static bool ct_expressible(struct ct_file *cf, struct i2c_msg *m, u32 nmsgs, u32 ntx)
{
	struct contego_i2c_formless why;
	u32 funcs = i2c_get_functionality(cf->adap);

	lockdep_assert_held(&ct.lock);
	if (contego_i2c_call_has_forms((struct contego_i2c_msg *)m, nmsgs, ct.txs, NULL, ntx, funcs,
				       &why))
		return true;
	if (ct.policy)
		ct_record_formless(ct_task_of_current(ct.policy), cf->bus, funcs, &why);
	return false;
}

/* The one message of a read() or write(), planned and checked as an
 * I2C_RDWR of it is. Under ct.lock.
 */
bool ct_msg_expressible(struct ct_file *cf, struct i2c_msg *m)
{
	lockdep_assert_held(&ct.lock);
	return ct_expressible(cf, m, 1, ct_plan_msgs(m, 1));
}

static long ct_ioctl_rdwr(struct ct_file *cf, struct i2c_msg *msgs, u32 nmsgs,
			  u8 __user **user_bufs)
{
	u32 ntx, decider, i;
	u64 hold_until;
	u8 action;
	u16 task;
	long ret = 0;
	int r;

	if (mutex_lock_killable(&ct.lock))
		return -EINTR;
	ntx = ct_plan_msgs(msgs, nmsgs);
	if (!ct_expressible(cf, msgs, nmsgs, ntx)) {
		/* No form on this adapter: refused before the core decides, as
		 * i2c_transfer refuses it on an SMBus-only adapter.
		 */
		mutex_unlock(&ct.lock);
		return -EOPNOTSUPP;
	}
	r = ct_enter(ct_call_writes(ntx), &task);
	if (r < 0) {
		mutex_unlock(&ct.lock);
		return r;
	}
	if (r > 0) /* held: ct.txs served other calls meanwhile */
		ntx = ct_plan_msgs(msgs, nmsgs);
	action = ct_decide(cf, task, msgs, nmsgs, ntx, &decider, &hold_until);
	if (action == CT_REFUSE) {
		ret = ct_refusal(decider);
	} else if ((action == CT_PERFORM || action == CT_SUBSTITUTE) &&
		   (ntx > 1 || ct.txs[0].kind == CONTEGO_TX_WRITE) &&
		   contego_i2c_acts_as_sent(ct.txs, ct.verdicts, ntx) &&
		   ct_xfer(cf->adap, cf, msgs, nmsgs, true) == 0) {
		/* Every write exactly as sent: the program's one combined transfer. */
		ret = ct_xfer(cf->adap, cf, msgs, nmsgs, false);
	} else if (action == CT_PERFORM || action == CT_SUBSTITUTE) {
		/* In message order, only what the core allowed or substituted. */
		for (i = 0; i < ntx && ret == 0; i++) {
			const struct contego_i2c_tx *tx = &ct.txs[i];
			int joined;

			if (i + 1 < ntx && contego_i2c_write_then_read(tx, tx + 1) &&
			    ct_emit_with_read(cf->adap, cf, &ct.verdicts[i],
					      &msgs[tx[1].first_msg], &joined)) {
				ret = joined; /* the write and its answer, together */
				i++;
			} else if (tx->kind == CONTEGO_TX_WRITE) {
				ret = ct_perform_emits(cf->adap, cf, &ct.verdicts[i],
						       tx->ten ? I2C_M_TEN : 0);
			} else {
				ret = ct_xfer(cf->adap, cf, &msgs[tx->first_msg], tx->msg_count,
					      false);
			}
		}
	} else {
		for (i = 0; i < nmsgs; i++) /* ignored: reads read zeros */
			if (msgs[i].flags & I2C_M_RD)
				memset(msgs[i].buf, 0, msgs[i].len);
	}
	mutex_unlock(&ct.lock);
	ct_hold_after(hold_until);
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
 * msgs.
 */
long ct_rdwr_msgs(struct ct_file *cf, struct i2c_msg *msgs, u32 nmsgs)
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
		 * mangling flag would let a checked read act as a write.
		 */
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
		/* i2c-dev's RECV_LEN rule. The length stays the buffer's, as
		 * the planner sees it; ct_xfer presets buf[0] for the driver.
		 */
		if ((msgs[i].flags & I2C_M_RECV_LEN) &&
		    (!(msgs[i].flags & I2C_M_RD) || msgs[i].len < 1 || msgs[i].buf[0] < 1 ||
		     msgs[i].len < msgs[i].buf[0] + I2C_SMBUS_BLOCK_MAX)) {
			i++;
			ret = -EINVAL;
			break;
		}
	}
	if (ret == 0)
		ret = ct_ioctl_rdwr(cf, msgs, nmsgs, user_bufs);
	while (i-- > 0)
		if (!IS_ERR_OR_NULL(msgs[i].buf))
			kfree(msgs[i].buf);
	kfree(user_bufs);
	return ret;
}

long ct_rdwr(struct ct_file *cf, unsigned long arg)
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

/* A process call the core allowed or substituted, into `data`: as the
 * program's call when its write goes out as sent (`w`: the call's write,
 * else NULL) and the pair has a form; else the one emit and the answer
 * together (ct_emit_with_read); else, as the monitor performs one, the
 * write's emits, then the answer read on its own (ct_xfer's form). Nothing
 * is written when the read has no form on this adapter. `answer`: the
 * model's read message, whose length counts the device's PEC when the call
 * has one (contego_i2c_smbus_msgs); `pec`: the PEC of all before that byte
 * but the answer, which the answer's PEC must continue to (-EBADMSG, as
 * i2c-core, and as the monitor's clients check it). 0 or -errno.
 */
static int ct_proc_call(struct ct_file *cf, int size, union i2c_smbus_data *data,
			const struct i2c_msg *w, const struct i2c_msg *answer, u8 pec)
{
	u8 buf[1 + I2C_SMBUS_BLOCK_MAX] = { 1 }; /* RECV_LEN's preset */
	struct i2c_msg m = { .addr = cf->addr, .flags = I2C_M_RD | (cf->flags & I2C_M_TEN),
			     .len = answer->len, .buf = buf };
	struct i2c_msg pair[2];
	int ret;

	if (size == I2C_SMBUS_BLOCK_PROC_CALL) {
		m.flags |= I2C_M_RECV_LEN;
		m.len = sizeof(buf);
	}
	if (w) {
		pair[0] = *w;
		pair[1] = m;
	}
	if (w && ct_xfer(cf->adap, cf, pair, 2, true) == 0) {
		ret = ct_xfer(cf->adap, cf, pair, 2, false);
		m.len = pair[1].len;
	} else if (!ct_emit_with_read(cf->adap, cf, &ct.verdicts[0], &m, &ret)) {
		ret = ct_xfer(cf->adap, cf, &m, 1, true);
		if (ret == 0)
			ret = ct_perform_emits(cf->adap, cf, &ct.verdicts[0], cf->flags);
		if (ret == 0)
			ret = ct_xfer(cf->adap, cf, &m, 1, false);
	}
	if (ret < 0)
		return ret;
	if (size == I2C_SMBUS_PROC_CALL) {
		if (m.len == 3 && contego_smbus_pec(pec, buf, 2) != buf[2])
			return -EBADMSG;
		data->word = buf[0] | (buf[1] << 8);
		return 0;
	}
	if (buf[0] > I2C_SMBUS_BLOCK_MAX || m.len < 1 + buf[0])
		return -EPROTO;
	memcpy(data->block, buf, 1 + buf[0]);
	return 0;
}

/* I2C_SMBUS with its arguments copied in (native or compat). */
long ct_smbus(struct ct_file *cf, struct i2c_smbus_ioctl_data a)
{
	union i2c_smbus_data data;
	u8 bytes[CONTEGO_SMBUS_DATA_BYTES]; /* the union as bytes, word as [lo, hi] */
	u8 wire[CONTEGO_SMBUS_WIRE_BYTES], rbuf[CONTEGO_SMBUS_DATA_BYTES - 1];
	struct i2c_msg m[2];
	u32 datasize = 0, n, nm, decider;
	u64 hold_until;
	bool read, proc, as_sent;
	int r;
	u8 action;
	u16 task, client;
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

	/* The messages this call puts on the wire: the shared model's table
	 * (contego/i2c_plan.h, as the monitor's decoder makes them); then the
	 * transactions and the forms come from it too, as for I2C_RDWR.
	 */
	memcpy(bytes, data.block, sizeof(bytes));
	if (a.size == I2C_SMBUS_WORD_DATA || a.size == I2C_SMBUS_PROC_CALL) {
		bytes[0] = data.word & 0xff;
		bytes[1] = data.word >> 8;
	}
	/* PEC, where the adapter sends one, as the shared model has it: a
	 * write's is a byte of the write, which the core checks and the call
	 * itself puts on the wire; a read's comes from the device and i2c-core
	 * compares it; the counted reads go without.
	 */
	BUILD_BUG_ON(I2C_CLIENT_PEC != CONTEGO_I2C_CLIENT_PEC);
	client = cf->flags & I2C_M_TEN;
	if (contego_i2c_pec_on_wire(cf->flags & I2C_CLIENT_PEC, i2c_get_functionality(cf->adap)) &&
	    contego_i2c_smbus_pec_kept(a.size, a.read_write == I2C_SMBUS_READ))
		client |= I2C_CLIENT_PEC;
	r = contego_i2c_smbus_msgs(cf->addr, client, a.read_write == I2C_SMBUS_READ, a.command,
				   a.size, bytes, (struct contego_i2c_msg *)m, wire, rbuf);
	if (r < 0)
		return r;
	nm = r;

	if (mutex_lock_killable(&ct.lock))
		return -EINTR;
	/* ct.txs is shared scratch, used under ct.lock only. */
	n = a.size == I2C_SMBUS_QUICK ? 1 : ct_plan_msgs(m, nm);
	if (a.size == I2C_SMBUS_QUICK)
		ct.txs[0] = (struct contego_i2c_tx){ .kind = CONTEGO_TX_QUICK, .addr = cf->addr,
						     .ten = !!(cf->flags & I2C_M_TEN), .msg_count = 1 };
	if (!ct_expressible(cf, m, nm, n)) {
		mutex_unlock(&ct.lock);
		return -EOPNOTSUPP; /* no form on this adapter: nothing decided */
	}
	/* An SMBus call writes unless it is a quick command or a read (a
	 * process call writes).
	 */
	ret = ct_enter(a.size != I2C_SMBUS_QUICK && !read, &task);
	if (ret < 0) {
		mutex_unlock(&ct.lock);
		return ret;
	}
	if (ret > 0 && a.size != I2C_SMBUS_QUICK) /* held: ct.txs served other calls */
		n = ct_plan_msgs(m, nm);
	action = ct_decide(cf, task, m, nm, n, &decider, &hold_until);
	as_sent = !read && contego_i2c_emits_as_sent(&ct.verdicts[0], cf->addr, wire, ct.txs[0].len);
	if (action == CT_REFUSE) {
		ret = ct_refusal(decider);
	} else if (action == CT_IGNORE || action == CT_SAFE_STATE) {
		ret = 0;
		memset(&data, 0, sizeof(data));
	} else if (a.size == I2C_SMBUS_QUICK || read ||
		   (ct.verdicts[0].emit_count == 1 && as_sent)) {
		/* Exactly what was asked: the call itself, from our copy. */
		ret = ct_bus_smbus(cf->adap, cf, cf->addr, client, a.read_write, a.command,
				   a.size, (a.size == I2C_SMBUS_QUICK ||
					    (a.size == I2C_SMBUS_BYTE && !read)) ? NULL : &data);
	} else if (as_sent && !proc) {
		/* The write's bytes, checked register by register, as one
		 * message in the planner's form (as the monitor sends it).
		 */
		ret = ct_xfer(cf->adap, cf, m, 1, false);
	} else if (proc) {
		ret = ct_proc_call(cf, a.size, &data, as_sent ? &m[0] : NULL, &m[1],
				   contego_i2c_answer_pec((struct contego_i2c_msg *)m, 2));
	} else {
		ret = ct_perform_emits(cf->adap, cf, &ct.verdicts[0], cf->flags);
	}
	mutex_unlock(&ct.lock);
	ct_hold_after(hold_until);
	if (ret < 0)
		return ret;
	if ((read || proc) && datasize && copy_to_user(a.data, &data, datasize))
		return -EFAULT;
	return 0;
}
