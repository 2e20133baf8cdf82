/* Sessions as both clients count and end them (docs/kernel-client.md,
 * "Sessions"; docs/policy-language.md, `sessions`): a task's live sessions
 * are counted by unit, and a process that exits cleanly inside a process
 * group whose leader lives hands the end of its session to that leader. So
 * the i2cset runs of a script, or a controller and its forked worker, are one
 * session of the task under contego.ko and under the monitor alike: neither
 * counts them twice against `sessions`, and the task's safe state is driven
 * when the script ends, not between its commands.
 *
 * Freestanding C ABI (src/i2cdev): a unit is an opaque non-zero key the
 * host chooses (contego.ko: a struct pid's address; the monitor: a pid). */
#ifndef CONTEGO_SESSION_ROOM_H_
#define CONTEGO_SESSION_ROOM_H_

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The distinct units a count keeps: the most `sessions` a policy may give a
 * task (contego.ko's CONTEGO_KMOD_MAX_TASK_SESSIONS). */
#define CONTEGO_ROOM_UNITS 64

/* The unit of a live process: the process group it is in (`group`, 0 when it
 * has none) if it is not that group's leader and the leader lives; the
 * process itself otherwise. */
uintptr_t contego_session_unit(uintptr_t process, uintptr_t group, int group_leader_lives);

/* Whether the session of a process that exited with wait status
 * `exit_status` goes on with its group's leader instead of ending now: a
 * clean exit (status 0) of a process that is not its group's leader, while
 * that leader lives. Killed, crashed or failing, a process's session ends
 * at once, wherever it stands. */
int contego_session_hands_to_leader(int exit_status, uintptr_t process, uintptr_t group,
                                    int group_leader_lives);

/* One count of a task's live sessions for a caller that would open one. */
struct contego_session_room {
  uintptr_t mine;   /* the caller's unit */
  uint32_t allowed; /* the task's `sessions`, at most CONTEGO_ROOM_UNITS */
  uint32_t n;       /* distinct other units seen, at most `allowed` */
  int with_mine;    /* a live session of the task is the caller's unit's */
  uintptr_t seen[CONTEGO_ROOM_UNITS];
};

void contego_room_start(struct contego_session_room *r, uintptr_t mine, uint32_t allowed);
/* One live session of the task, by its unit. 0: the answer is known (stop). */
int contego_room_count(struct contego_session_room *r, uintptr_t unit);
/* Whether the caller may open a session: its unit has one already, or the
 * task has fewer live units than it is allowed. */
int contego_room_left(const struct contego_session_room *r);

#ifdef __cplusplus
}
#endif

#endif /* CONTEGO_SESSION_ROOM_H_ */
