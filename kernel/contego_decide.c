// SPDX-License-Identifier: GPL-2.0
/* contego.ko: the decision of one call. */
#include "contego.h"

/* A record of the call could not be taken: nothing of it acts, it fails
 * with EIO, and the devices go to their safe state -- once per run of lost
 * records, since nothing acts until records are taken again. Under ct.lock.
 */

static u8 ct_fail_unrecorded(struct ct_policy *p, u32 *decider)
{
	lockdep_assert_held(&ct.lock);
	contego_abort_transfer(p->checker, CONTEGO_REJECT);
	ct.stats.audit_refused++;
	ct.stats.refused++;
	ct.verdicts[0].decision = CONTEGO_REJECT;
	ct.verdicts[0].reply_errno = EIO;
	*decider = 0;
	if (!ct.failing_closed) {
		ct.failing_closed = true;
		pr_warn_ratelimited("contego: an audit record could not be taken (%s): failing closed, devices to their safe state\n",
				    ct.ring.reader ? "the ring is full" : "no audit reader");
		ct_drive_safe_states(p, CONTEGO_KMOD_SAFE_UNRECORDED, NULL);
	}
	return CT_REFUSE;
}

/* Whether the call writes: its first `checked` transactions include a write. */
bool ct_call_writes(u32 checked)
{
	u32 i;

	lockdep_assert_held(&ct.lock);
	for (i = 0; i < checked; i++)
		if (ct.txs[i].kind == CONTEGO_TX_WRITE)
			return true;
	return false;
}

/* Every write of the call emits the bytes the program sent, at its address. */
static void ct_act_as_sent(u32 n)
{
	u32 i;

	lockdep_assert_held(&ct.lock);
	for (i = 0; i < n; i++) {
		contego_verdict *v = &ct.verdicts[i];
		u32 len = min_t(u32, ct.txs[i].len, CONTEGO_MAX_EMIT_BYTES);

		v->decision = CONTEGO_ALLOW;
		v->reply_errno = 0;
		v->addr = ct.txs[i].addr;
		v->emit_count = 0;
		if (ct.txs[i].kind != CONTEGO_TX_WRITE)
			continue;
		v->emit_count = 1;
		v->emit_len[0] = len;
		v->emit_bytes_used = len;
		memcpy(v->emit_bytes, ct.txs[i].bytes, len);
	}
}

/* Whether everything the verdicts of the call send has a form on its
 * adapter, by the shared model's rule (contego_i2c_call_has_forms, the
 * monitor's too): else an earlier part of the call would act before a later
 * one failed at the bus. A refusal is recorded. Under ct.lock.
 */
static bool ct_sendable(struct ct_file *cf, u16 task, const struct i2c_msg *msgs, u32 nmsgs,
			u32 n)
{
	struct contego_i2c_formless why;
	u32 funcs = i2c_get_functionality(cf->adap);

	lockdep_assert_held(&ct.lock);
	if (contego_i2c_call_has_forms((const struct contego_i2c_msg *)msgs, nmsgs, ct.txs,
				       ct.verdicts, n, funcs, &why))
		return true;
	ct_record_formless(task, cf->bus, funcs, &why);
	return false;
}

/* Decides the call of `task` (ct_enter's) in ct.txs[0..n), made of `msgs`.
 * Under ct.lock. *hold_until: when the caller waits after its answer
 * (ct_hold_after), 0: not at all.
 */
u8 ct_decide(struct ct_file *cf, u16 task, const struct i2c_msg *msgs, u32 nmsgs, u32 n,
	     u32 *decider, u64 *hold_until)
{
	struct ct_policy *p = ct.policy;
	struct ct_session *fresh = NULL;
	u8 result;
	contego_transaction tx;
	u32 checked = 0, i, job;
	bool formless;
	u8 action;
	u64 now = div_u64(ktime_get_ns(), 1000);

	lockdep_assert_held(&ct.lock);
	*decider = 0;
	*hold_until = 0;
	if (!p) {
		/* No verified image: deny, as the core's kNotLoaded would. */
		ct.verdicts[0].decision = CONTEGO_REJECT;
		ct.verdicts[0].reply_errno = EPERM;
		ct.stats.refused++;
		return CT_REFUSE;
	}
	if (task != CONTEGO_NONE && ct_call_writes(n) && !ct_session_find(p, task)) {
		if (!ct_session_room(p, task)) {
			/* The task has its `sessions` live: as the monitor refuses
			 * a further hello, the call is refused before the core
			 * sees it, and audited.
			 */
			ct.verdicts[0].decision = CONTEGO_REJECT;
			ct.verdicts[0].reply_errno = EACCES;
			ct.stats.sessions_limited++;
			ct.stats.refused++;
			ct_record_session_refused(p, task);
			return CT_REFUSE;
		}
		fresh = ct_session_prepare(p, task);
		if (!fresh) {
			/* No session, no safe state at its end: the call does not act. */
			ct.verdicts[0].decision = CONTEGO_REJECT;
			ct.verdicts[0].reply_errno = EAGAIN;
			ct.stats.sessions_refused++;
			ct.stats.refused++;
			ct_record_sessions_full(p, task, now);
			pr_warn_ratelimited("contego: %u sessions open: a call of task %u refused (EAGAIN)\n",
					    ct.session_count, task);
			return CT_REFUSE;
		}
	}
	job = ct_job(p, task, now);
	ct.complain_now = task < CONTEGO_MAX_TASKS && ((p->complain >> task) & 1);
	contego_begin_transfer(p->checker);
	for (i = 0; i < n; i++) {
		contego_verdict *v = &ct.verdicts[i];

		memset(&tx, 0, sizeof(tx));
		tx.task = task;
		tx.bus = cf->bus;
		tx.kind = ct.txs[i].kind;
		tx.addr = ct.txs[i].addr;
		tx.ten_bit = ct.txs[i].ten;
		tx.job = job;
		tx.len = ct.txs[i].len;
		tx.bytes = ct.txs[i].bytes;
		tx.now_us = now;
		v->decision = CONTEGO_REJECT; /* fail closed if the core leaves it */
		v->reply_errno = EPERM;
		v->emit_count = 0;
		ct.audit_lost = false;
		contego_check(p->checker, &tx, v);
		ct.stats.checks++;
		checked = i + 1;
		if (ct.audit_lost) {
			result = ct_fail_unrecorded(p, decider);
			goto out;
		}
		if (ct_trace)
			pr_info("contego: task %u job %u bus %u addr 0x%02x kind %u len %u: %s (%s) emits %u\n",
				task, job, tx.bus, tx.addr, tx.kind, tx.len,
				contego_decision_name(v->decision), contego_reason_name(v->reason),
				v->emit_count);
		if (v->decision == CONTEGO_REJECT)
			break;
	}
	ct.failing_closed = false; /* every record of this call was taken */
	action = contego_combine_transfer(ct.verdicts, checked, decider);
	/* What the verdicts send, before anything of the call acts (a
	 * substitute in complain mode is not sent: the call acts as sent).
	 */
	formless = (action == CT_PERFORM || (action == CT_SUBSTITUTE && !ct.complain_now)) &&
		   !ct_sendable(cf, task, msgs, nmsgs, n);
	if (formless) {
		/* Refused whole, as the monitor refuses it: nothing acts. */
		contego_abort_transfer(p->checker, CONTEGO_REJECT);
		ct.verdicts[0].reply_errno = EOPNOTSUPP;
		*decider = 0;
		action = CT_REFUSE;
	} else if (action == CT_PERFORM || action == CT_SUBSTITUTE) {
		contego_commit_transfer(p->checker);
	} else {
		contego_abort_transfer(p->checker, action == CT_IGNORE ? CONTEGO_IGNORE :
						   action == CT_REFUSE ? CONTEGO_REJECT :
									 CONTEGO_FAILSAFE);
	}
	if (ct.complain_now && action != CT_PERFORM && !formless) {
		/* Complain mode: recorded as the policy decides, acted as sent. The
		 * model was undone as for a drop (the monitor's act_as_sent_locked).
		 */
		ct_act_as_sent(n);
		action = CT_PERFORM;
	}
	ct.complain_now = false;
	switch (action) {
	case CT_PERFORM:
		ct.stats.performed++;
		break;
	case CT_IGNORE:
		ct.stats.ignored++;
		break;
	case CT_SUBSTITUTE:
	case CT_SAFE_STATE:
		ct.stats.failsafe++;
		break;
	default:
		ct.stats.refused++;
		break;
	}
	if (action == CT_SAFE_STATE) {
		/* Several messages, one fail-safe: the device's declared safe state
		 * instead of any of them (as the monitor's drive_transfer_safe_states).
		 */
		for (i = 0; i < checked; i++)
			if (ct.verdicts[i].decision == CONTEGO_FAILSAFE)
				ct_drive_safe_state(p, ct.verdicts[i].device, CONTEGO_KMOD_SAFE_TRANSFER);
	}
	if (action == CT_IGNORE && task < CONTEGO_KMOD_MAX_TASKS && p->ignore_errno[task]) {
		/* The policy's `ignore_errno`: nothing acted, and the call says so. */
		ct.verdicts[*decider].reply_errno = p->ignore_errno[task];
		action = CT_REFUSE;
	}
	result = action;
	/* Counted as acting or not, for the over-budget hold: a call that
	 * writes (a read acts nothing and is never held).
	 */
	if (task != CONTEGO_NONE && ct_call_writes(n))
		*hold_until = ct_charge_after(p, task, action == CT_PERFORM ||
						       action == CT_SUBSTITUTE);
out:
	/* A session begins with the first call that acts as the task: a write
	 * the core allowed or substituted (docs/kernel-client.md "Sessions").
	 */
	if (fresh && (result == CT_PERFORM || result == CT_SUBSTITUTE) && ct_call_writes(checked))
		ct_session_open(fresh);
	else if (fresh)
		ct_session_free(fresh);
	return result;
}

int ct_refusal(u32 decider)
{
	u8 e = ct.verdicts[decider].reply_errno;

	return -(e ? e : EPERM);
}
