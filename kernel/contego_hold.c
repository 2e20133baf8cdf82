// SPDX-License-Identifier: GPL-2.0
/* contego.ko: the job grid and the over-budget hold (docs/kernel-client.md "Budget"). */
#include "contego.h"

/* The task's job at `now` on its period grid (1 = the first), starting the
 * grid at its first transaction; 0 for a task without a period.
 */
u32 ct_job(struct ct_policy *p, u16 task, u64 now)
{
	u32 period = task < CONTEGO_MAX_TASKS ? contego_task_period_us(p->checker, task) : 0;

	lockdep_assert_held(&ct.lock);
	if (period == 0)
		return 0; /* no task: the core's own windows */
	if (!(p->phase_set & (1u << task))) {
		p->phase_set |= 1u << task;
		p->phase_us[task] = contego_grid_first_release(0, 0, period, now);
	}
	return contego_grid_job(p->phase_us[task], period, now);
}

/* A hold, audited at most once a second per task (the count since the
 * last record), and the first of each task under a policy in the kernel log.
 */
static void ct_report_hold(struct ct_policy *p, u16 task, u32 job, u64 budget, u64 now,
			   const char *what)
{
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
		pr_info("contego: task %u: more than %llu %s in one job (budget_factor x actuations); the thread sending more waits for the next release\n",
			task, budget, what);
	}
}

/* Whether the hold counts `task`'s calls: a budget factor, a task with a
 * period and actuations, not complaining (observed as it runs, never held).
 * Sets its period and actuations.
 */
static bool ct_budgeted(struct ct_policy *p, u16 task, u32 *period, u64 *actuations)
{
	lockdep_assert_held(&ct.lock);
	if (p->budget_factor == 0 || task >= CONTEGO_KMOD_MAX_TASKS || (p->complain >> task) & 1)
		return false;
	*period = contego_task_period_us(p->checker, task);
	*actuations = p->actuations[task];
	return *period != 0 && *actuations != 0;
}

/* Before a call that may act (the monitor's hold_if_over_budget, the shared
 * model's contego_budget_before): once budget_factor x its actuations of
 * the task's calls acted in one job, the next is charged to the next job and
 * waits for that job's release before it is checked. Under ct.lock.
 * Returns 0 (go on now) or the release (CLOCK_MONOTONIC, us) to sleep until.
 */
static u64 ct_charge(struct ct_policy *p, u16 task, u64 now)
{
	u64 actuations, budget;
	u32 period, job, charged;

	if (!ct_budgeted(p, task, &period, &actuations))
		return 0;
	budget = (u64)p->budget_factor * actuations;
	job = ct_job(p, task, now);
	charged = contego_budget_before(&p->budget[task], job, period, budget);
	if (charged == job)
		return 0;
	ct_report_hold(p, task, job, budget, now, "acting transfers");
	return p->phase_us[task] + (u64)(charged - 1) * period;
}

/* After a call's decision (the monitor's charge_transfer_locked): counts it
 * as acting or not. One that did not act past budget_factor x
 * max(actuations, CT_NON_ACTING_FLOOR) returns the release its caller
 * waits for after its answer (ct_hold_after); 0: none. Under ct.lock.
 */
u64 ct_charge_after(struct ct_policy *p, u16 task, bool acted)
{
	u64 actuations, budget, now = div_u64(ktime_get_ns(), 1000);
	u32 period, job;

	if (!ct_budgeted(p, task, &period, &actuations))
		return 0;
	budget = (u64)p->budget_factor * max_t(u64, actuations, CT_NON_ACTING_FLOOR);
	job = ct_job(p, task, now);
	if (!contego_budget_after(&p->budget[task], job, period, acted, budget))
		return 0;
	ct_report_hold(p, task, job, budget, now, "transfers that did not act");
	return p->phase_us[task] + (u64)job * period;
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
 * hold short, the call does nothing (restarted, it is held again). A process refused for its task's
 * `sessions` is not charged: it spends nothing of the task's budget.
 */
int ct_enter(bool writes, u16 *task)
{
	struct ct_policy *p;
	u64 charged_gen = 0, until;
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
		mutex_unlock(&ct.lock);
		ret = ct_sleep_until(until);
		mutex_lock(&ct.lock); /* not killable: the caller holds it on return */
		slept = 1;
		if (ret)
			return ret; /* nothing was counted: counts come after a decision */
	}
}

/* The wait after a call's answer that ct_charge_after asked for (`until`, 0:
 * none), without ct.lock. A signal ends it early: the call's result stands.
 */
void ct_hold_after(u64 until)
{
	if (until)
		ct_sleep_until(until);
}
