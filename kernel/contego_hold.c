// SPDX-License-Identifier: GPL-2.0
/* contego.ko: the job grid and the over-budget hold (docs/kernel-client.md "Budget"). */
#include "contego.h"

u32 ct_job(struct ct_policy *p, u16 task, u64 now)
{
	u32 period = task < CONTEGO_MAX_TASKS ? contego_task_period_us(p->checker, task) : 0;

	lockdep_assert_held(&ct.lock);
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


/* The monitor's hold_if_over_budget: each task's transfers that write are
 * counted per job on its period grid; past budget_factor x its actuations,
 * the transfer is charged to the next job and waits for that job's release
 * before it is checked. A transfer charged to a later job than the current
 * one (another thread of the task was held before it) waits for that
 * job's release too. Under ct.lock. Returns when the caller may go on: 0
 * now, else the release (CLOCK_MONOTONIC, us) to sleep until.
 */
static u64 ct_charge(struct ct_policy *p, u16 task, u64 now)
{
	u32 period, job;
	u64 budget;

	lockdep_assert_held(&ct.lock);
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
	ct.stats.holds++;
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
 * comes first.
 */
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

/* The start of a call, under ct.lock: the caller's task (into *task), and,
 * for a call that writes, the over-budget hold, with ct.lock dropped while
 * it sleeps. 0: go on; 1: go on, but ct.lock was dropped (the call's
 * scratch in ct.txs must be made again); -ERESTARTSYS: a signal cut the
 * hold short, the call does nothing (its charge is given back; restarted,
 * it is charged and held again). A process refused for its task's
 * `sessions` is not charged: it spends nothing of the task's budget.
 */
int ct_enter(bool writes, u16 *task)
{
	struct ct_policy *p;
	u64 charged_gen = 0, until;
	u32 charged_job = 0;
	int slept = 0, ret;

	lockdep_assert_held(&ct.lock);
	for (;;) {
		p = ct.policy;
		*task = p ? ct_task_of_current(p) : CONTEGO_NONE;
		if (!writes || !p || *task == CONTEGO_NONE || p->gen == charged_gen ||
		    (!ct_session_find(p, *task) && !ct_session_room(p, *task)))
			return slept;
		until = ct_charge(p, *task, div_u64(ktime_get_ns(), 1000));
		if (until == 0)
			return slept;
		charged_gen = p->gen;
		charged_job = p->budget_job[*task];
		mutex_unlock(&ct.lock);
		ret = ct_sleep_until(until);
		mutex_lock(&ct.lock); /* not killable: the caller holds it on return */
		slept = 1;
		if (ret) {
			p = ct.policy; /* the one charged, unless another was loaded meanwhile */
			if (p && p->gen == charged_gen && p->budget_job[*task] == charged_job &&
			    p->budget_used[*task] > 0)
				p->budget_used[*task]--;
			return ret;
		}
	}
}
