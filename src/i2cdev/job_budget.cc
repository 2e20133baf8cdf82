// contego/job_budget.h: the job grid and the over-budget hold's counts.
// Freestanding: linked into contego.ko as well as the monitor.
#include "contego/job_budget.h"

// The functions keep the C linkage of their declarations in the header.

// A new release (or a new grid): a fresh budget.
static void renew(contego_job_budget* b, uint32_t job, uint64_t period_us) {
  if (job > b->job || period_us != b->period_us) *b = {period_us, job, 0, 0};
}

uint32_t contego_grid_job(uint64_t phase_us, uint64_t period_us, uint64_t now_us) {
  if (period_us == 0) return 0;
  if (now_us <= phase_us) return 1;
  return static_cast<uint32_t>((now_us - phase_us) / period_us + 1);
}

uint64_t contego_grid_first_release(int has_declared, uint64_t declared_us, uint64_t period_us,
                                    uint64_t contact_us) {
  if (!has_declared || period_us == 0) return contact_us;
  if (contact_us < declared_us) return declared_us;  // before it, the contact is in job 1 too
  return declared_us + (contact_us - declared_us) / period_us * period_us;
}

uint32_t contego_budget_before(contego_job_budget* b, uint32_t job, uint64_t period_us,
                               uint64_t budget) {
  renew(b, job, period_us);
  // Past the budget, a transfer is the first of the next job's. One that
  // arrives while earlier ones are held into a later job (another thread or
  // process of the task) is charged to that job and waits for it too.
  if (b->acted >= budget) *b = {period_us, b->job + 1, 0, 0};
  return b->job;
}

int contego_budget_after(contego_job_budget* b, uint32_t job, uint64_t period_us, int acted,
                         uint64_t dropped_budget) {
  renew(b, job, period_us);
  if (acted) {
    ++b->acted;
    return 0;
  }
  return ++b->dropped > dropped_budget ? 1 : 0;
}
