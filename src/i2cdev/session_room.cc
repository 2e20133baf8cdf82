// contego/session_room.h: how both clients count and end sessions.
// Freestanding: linked into contego.ko as well as the monitor.
#include "contego/session_room.h"

// The functions keep the C linkage of their declarations in the header.

static bool in_a_led_group(uintptr_t process, uintptr_t group, int group_leader_lives) {
  // A process in a group it does not lead, the leader alive: the group is
  // what the user started (a script, a controller that forked).
  return group != 0 && group != process && group_leader_lives != 0;
}

uintptr_t contego_session_unit(uintptr_t process, uintptr_t group, int group_leader_lives) {
  return in_a_led_group(process, group, group_leader_lives) ? group : process;
}

int contego_session_hands_to_leader(int exit_status, uintptr_t process, uintptr_t group,
                                    int group_leader_lives) {
  return exit_status == 0 && in_a_led_group(process, group, group_leader_lives) ? 1 : 0;
}

void contego_room_start(contego_session_room* r, uintptr_t mine, uint32_t allowed) {
  r->mine = mine;
  r->allowed = allowed < CONTEGO_ROOM_UNITS ? allowed : CONTEGO_ROOM_UNITS;
  r->n = 0;
  r->with_mine = 0;
}

int contego_room_count(contego_session_room* r, uintptr_t unit) {
  if (r->with_mine) return 0;
  if (unit == r->mine) {  // one session with it: its processes share it
    r->with_mine = 1;
    return 0;
  }
  uint32_t i = 0;
  while (i < r->n && r->seen[i] != unit) ++i;
  if (i == r->n && r->n < r->allowed) r->seen[r->n++] = unit;
  return 1;
}

int contego_room_left(const contego_session_room* r) {
  return r->with_mine || r->n < r->allowed ? 1 : 0;
}
