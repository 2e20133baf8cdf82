// SPDX-License-Identifier: GPL-2.0
/* contego.ko: sessions (docs/kernel-client.md "Sessions"). */
#include "contego.h"

static_assert(CONTEGO_ROOM_UNITS == CONTEGO_KMOD_MAX_TASK_SESSIONS);

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
 * context, under ct.lock. The unload takes every session off its wait queue
 * and drains the work before the checker and the module go.
 */
void ct_session_record(struct contego_kmod_record *r, const struct ct_session *s)
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
 * queues the work; nothing here sleeps or touches the bus.
 */
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
			if (contego_session_hands_to_leader(s->status, (uintptr_t)s->watch, (uintptr_t)pg,
							    pg && !ct_thread_group_exited(pg)))
				s->leader = get_pid(pg);
		}
		rcu_read_unlock();
	}
	queue_work(ct.wq, &s->work);
	return 1;
}

static void ct_session_arm(struct ct_session *s)
{
	s->fired = false;
	init_waitqueue_func_entry(&s->wq, ct_session_wake);
	add_wait_queue(&s->watch->wait_pidfd, &s->wq);
}

/* Takes s off its wait queue unless its wake-up came first. True: taken
 * (nobody else will queue its work).
 */
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

void ct_session_free(struct ct_session *s)
{
	put_pid(s->leader);
	put_pid(s->watch);
	put_pid(s->proc);
	kfree(s);
}

/* The end of s: its task's actuators to their safe state. Under ct.lock. */
static void ct_session_end(struct ct_policy *p, struct ct_session *s)
{
	u32 mask = contego_task_actuates(p->checker, s->task), n = 0, tried = 0;
	u16 d;
	int r;

	lockdep_assert_held(&ct.lock);
	/* The session's own state (a sequence's position) ends with it, and
	 * the register writes it staged and never completed are dropped: they
	 * never reached a device (its records say how many).
	 */
	s->staged_dropped = contego_end_session(p->checker, s->task);
	for (d = 0; d < CONTEGO_MAX_DEVICES; d++) {
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
	ct.stats.session_ends++;
	pr_info("contego: task %u: session of pid %u ended (wait status 0x%x%s): %u of %u devices driven to their safe state\n",
		s->task, s->pid, s->status, s->phase == CT_S_LEADER ? ", with its group's leader" : "",
		n, tried);
}

static void ct_session_work(struct work_struct *w)
{
	struct ct_session *s = container_of(w, struct ct_session, work), *o;
	struct ct_policy *p;

	mutex_lock(&ct.lock);
	if (s->leader && !ct.unloading) {
		struct pid *leader = s->leader;

		s->leader = NULL;
		/* One session per task and group leader: the runs of a script end once. */
		list_for_each_entry(o, &ct.sessions, node) {
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
		 * wake-up already queued this work again.
		 */
		if (!ct_thread_group_exited(leader) || !ct_session_disarm(s)) {
			mutex_unlock(&ct.lock);
			return;
		}
	}
	p = ct.policy;
	if (!ct.unloading && p && p->gen == s->gen)
		ct_session_end(p, s);
drop:
	list_del(&s->node);
	ct.session_count--;
	ct.stats.sessions = ct.session_count;
	mutex_unlock(&ct.lock);
	ct_session_free(s);
}

/* The caller's open session of `task` (NULL: none). Under ct.lock. */
struct ct_session *ct_session_find(struct ct_policy *p, u16 task)
{
	struct pid *me = task_tgid(current);
	struct ct_session *s;

	lockdep_assert_held(&ct.lock);
	list_for_each_entry(s, &ct.sessions, node) {
		if (s->proc == me && s->task == task && s->gen == p->gen && s->phase == CT_S_PROCESS) {
			list_move(&s->node, &ct.sessions); /* the next call finds it first */
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
 * are one session, not several.
 */
static struct pid *ct_unit_of(struct task_struct *t)
{
	struct pid *pg = task_pgrp(t), *me = task_tgid(t);

	return (struct pid *)contego_session_unit((uintptr_t)me, (uintptr_t)pg,
						  pg && !ct_thread_group_exited(pg));
}

/* The unit of s while it lives; NULL once it has ended or is ending (its
 * process, or its group's leader, exited: its end is queued). Under ct.lock
 * and rcu_read_lock.
 */
static struct pid *ct_session_unit(struct ct_session *s)
{
	struct task_struct *t;
	struct pid *unit;
	unsigned long flags;

	lockdep_assert_held(&ct.lock);
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

/* Whether the caller may open a session of `task`: its unit already has a
 * live session of the task, or the task has fewer live units than its
 * `sessions`. Under ct.lock.
 */
bool ct_session_room(struct ct_policy *p, u16 task)
{
	u32 allowed = task < CONTEGO_KMOD_MAX_TASKS ? p->sessions[task] : 1;
	struct ct_session *s;
	struct pid *u;
	bool room;

	lockdep_assert_held(&ct.lock);
	rcu_read_lock();
	contego_room_start(&ct.room, (uintptr_t)ct_unit_of(current), allowed);
	list_for_each_entry(s, &ct.sessions, node) {
		if (s->task != task || s->gen != p->gen)
			continue;
		u = ct_session_unit(s);
		if (u && !contego_room_count(&ct.room, (uintptr_t)u))
			break;
	}
	room = contego_room_left(&ct.room);
	rcu_read_unlock();
	return room;
}

/* A session for the caller, made before its call is decided so that a call
 * that would act without one can be refused instead. Under ct.lock. NULL:
 * no room (max_sessions) or no memory.
 */
struct ct_session *ct_session_prepare(struct ct_policy *p, u16 task)
{
	struct ct_session *s;

	lockdep_assert_held(&ct.lock);
	if (ct.session_count >= ct_max_sessions)
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

/* Opens the prepared session: the caller's call acted. Under ct.lock. */
void ct_session_open(struct ct_session *s)
{
	lockdep_assert_held(&ct.lock);
	list_add(&s->node, &ct.sessions);
	ct.session_count++;
	ct.stats.sessions = ct.session_count;
	/* The caller runs: its thread group cannot have exited yet. */
	ct_session_arm(s);
}

/* The unload: every session off its wait queue, their work drained; the
 * safe state of every device is the unload's own.
 */
void ct_sessions_stop(void)
{
	struct ct_session *s, *n;

	mutex_lock(&ct.lock);
	ct.unloading = true;
	list_for_each_entry(s, &ct.sessions, node)
		ct_session_disarm(s);
	mutex_unlock(&ct.lock);
	destroy_workqueue(ct.wq); /* queued ends see ct.unloading and free themselves */
	ct.wq = NULL;
	list_for_each_entry_safe(s, n, &ct.sessions, node) {
		list_del(&s->node);
		ct_session_free(s);
	}
	ct.session_count = 0;
}

/* A call of `task` refused for the task's `sessions`: an audit record
 * naming the task and the process (not acting: it may be lost to the gap).
 */
void ct_record_session_refused(struct ct_policy *p, u16 task)
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
 * (not acting: it may be lost to the gap). Under ct.lock.
 */
void ct_record_sessions_full(struct ct_policy *p, u16 task, u64 now)
{
	struct contego_kmod_record r;

	lockdep_assert_held(&ct.lock);
	if (task >= CONTEGO_KMOD_MAX_TASKS)
		return;
	p->full_unreported[task]++;
	if (p->full_reported_us[task] != 0 && now - p->full_reported_us[task] < 1000000)
		return;
	ct_record_start(&r, CONTEGO_KMOD_REC_SESSIONS_FULL, true);
	r.task = task;
	r.count = p->full_unreported[task];
	r.field_count = 2;
	r.fields[0] = (s32)min_t(u32, ct.session_count, S32_MAX);
	r.fields[1] = (s32)min_t(u32, ct_max_sessions, S32_MAX);
	ct_push(&r, false);
	p->full_unreported[task] = 0;
	p->full_reported_us[task] = now;
}
