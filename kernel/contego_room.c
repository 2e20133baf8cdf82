// SPDX-License-Identifier: GPL-2.0
/* contego.ko: the room rule of a task's `sessions` (contego_room.h). Pure:
 * no lock, no allocation, no kernel object but the keys it compares.
 */
#include "contego_room.h"

void ct_room_start(struct ct_room *r, const void *mine, u32 allowed)
{
	r->mine = mine;
	r->allowed = allowed < CT_ROOM_UNITS ? allowed : CT_ROOM_UNITS;
	r->n = 0;
	r->with_mine = false;
}

bool ct_room_count(struct ct_room *r, const void *unit)
{
	u32 i;

	if (r->with_mine)
		return false;
	if (unit == r->mine) { /* one session with it: its processes share it */
		r->with_mine = true;
		return false;
	}
	for (i = 0; i < r->n && r->seen[i] != unit; i++)
		;
	if (i == r->n && r->n < r->allowed)
		r->seen[r->n++] = unit;
	return true;
}

bool ct_room_left(const struct ct_room *r)
{
	return r->with_mine || r->n < r->allowed;
}
