/* The job grid and the over-budget hold both clients share (docs/kernel-
 * client.md, "One i2c-dev model"; the monitor's hold_if_over_budget and
 * contego.ko's ct_enter): each task's transfers are counted per job of its
 * period grid. Transfers that acted (a write allowed or substituted) get a
 * budget of factor x N per job; past it, the next transfer that may act is
 * charged to the next job and waits, before it is checked, for that job's
 * release. Transfers that did not act (ignored, refused, only staged) get
 * their own budget; past it, the thread that sent one waits after its
 * answer for the next release. So a flood of dropped commands holds the
 * thread that floods, never the task's acting commands.
 *
 * Freestanding C ABI (src/i2cdev): pure arithmetic on the caller's state;
 * the caller keeps the grid's phase, sleeps and reports. */
#ifndef CONTEGO_JOB_BUDGET_H_
#define CONTEGO_JOB_BUDGET_H_

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* One task's counts. Zero-initialised: no job yet. */
struct contego_job_budget {
  uint64_t period_us; /* the grid the counts are on (a new policy may change it) */
  uint32_t job;       /* the job they are of; ahead of now while transfers are held */
  uint32_t acted;     /* transfers of that job that acted */
  uint32_t dropped;   /* transfers of that job that did not */
};

/* Job k (1-based) of a grid with phase `phase_us` spans
 * [phase + (k - 1) period, phase + k period); a time before the phase is in
 * job 1. 0 for a grid without a period. */
uint32_t contego_grid_job(uint64_t phase_us, uint64_t period_us, uint64_t now_us);

/* The phase of a grid first met at `contact_us`: the release of a declared
 * grid (`has_declared`, phase `declared_us`) at or before the contact, so
 * the contact is in job 1; the contact itself otherwise. */
uint64_t contego_grid_first_release(int has_declared, uint64_t declared_us, uint64_t period_us,
                                    uint64_t contact_us);

/* Before a transfer that may act, in job `job` of a grid of `period_us`,
 * with a budget of `budget` acting transfers per job: the job it is charged
 * to. When that is later than `job`, it waits for that job's release. */
uint32_t contego_budget_before(struct contego_job_budget *b, uint32_t job, uint64_t period_us,
                               uint64_t budget);

/* After its decision: counts it (`acted`). Returns 1 when a transfer that did
 * not act is past `dropped_budget`: its sender waits for the release after
 * `job`. */
int contego_budget_after(struct contego_job_budget *b, uint32_t job, uint64_t period_us, int acted,
                         uint64_t dropped_budget);

#ifdef __cplusplus
}
#endif

#endif /* CONTEGO_JOB_BUDGET_H_ */
