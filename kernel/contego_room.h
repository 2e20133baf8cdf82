/* SPDX-License-Identifier: GPL-2.0 */
/*
 * contego.ko: the room rule of a task's `sessions` (docs/kernel-client.md
 * "Sessions"), apart from the sessions themselves so that KUnit tests it
 * (kernel/kunit). A unit is an opaque key: the module passes struct pid
 * pointers (a process, or the process group a session was handed to).
 */
#ifndef CONTEGO_ROOM_H
#define CONTEGO_ROOM_H

#include <linux/types.h>

/* Cap of the distinct units kept: the policy's largest `sessions`. */
#define CT_ROOM_UNITS 64

struct ct_room {
	const void *mine;        /* the caller's unit */
	u32 allowed;             /* the task's `sessions` */
	u32 n;                   /* distinct other units seen, at most `allowed` */
	bool with_mine;          /* a live session of the task is the caller's unit's */
	const void *seen[CT_ROOM_UNITS];
};

void ct_room_start(struct ct_room *r, const void *mine, u32 allowed);
/* One live session of the task, by its unit. False: the answer is known. */
bool ct_room_count(struct ct_room *r, const void *unit);
/* Whether the caller may open a session: its unit has one already, or the
 * task has fewer live units than it is allowed.
 */
bool ct_room_left(const struct ct_room *r);

#endif /* CONTEGO_ROOM_H */
